//! Every test mesh in `../shared/meshes` through the public path: load, validate, normalize, query.
//! Expected counts come from `../shared/meshes/SOURCES.md` and DESIGN section 3.

use glam::DVec3;
use translucent::mesh::{MeshError, MeshSolid, Solid, TriMesh, ValidateOptions};

/// Deterministic points in a box (splitmix64).
fn points_in(lo: DVec3, hi: DVec3, count: usize, seed: u64) -> Vec<DVec3> {
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        (z ^ (z >> 31)) as f64 / u64::MAX as f64
    };
    (0..count)
        .map(|_| lo + (hi - lo) * DVec3::new(next(), next(), next()))
        .collect()
}

/// Normalizes to 50 mm, builds the solid and checks the fast classification against the
/// brute-force winding number at random points of the bounding box.
fn check_solid(name: &str, mesh: &TriMesh, points: usize) -> MeshSolid {
    let (mesh, transform) = mesh.normalized(50.0).unwrap();
    let (lo, hi) = mesh.bounds();
    assert!(
        ((hi - lo).max_element() - 50.0).abs() < 1e-9,
        "{name}: size {}",
        (hi - lo).max_element()
    );
    assert!((lo + hi).abs().max_element() < 1e-9, "{name}: not centred");
    assert!(transform.scale > 0.0);
    let solid = MeshSolid::new(mesh).unwrap();
    assert!(!solid.is_inverted(), "{name} winds outward");
    let pts = points_in(lo, hi, points, 11);
    let fast = solid.contains_many(&pts);
    let mut inside = 0;
    for (p, fast) in pts.iter().zip(fast) {
        let exact = solid.winding_number_exact(*p);
        assert_eq!(fast, exact.abs() > 0.5, "{name}: {p}: exact w = {exact}");
        inside += fast as usize;
    }
    assert!(
        inside > 0 && inside < points,
        "{name}: {inside} of {points} inside"
    );
    // Near the surface (within 0.2 mm of face centroids), where the quick estimate is most strained.
    let faces = &solid.mesh().indices;
    let jitter = points_in(DVec3::splat(-0.2), DVec3::splat(0.2), points, 12);
    let near: Vec<DVec3> = jitter
        .iter()
        .enumerate()
        .map(|(k, j)| {
            let tri = faces[(k * 7919) % faces.len()].map(|v| solid.mesh().positions[v as usize]);
            (tri[0] + tri[1] + tri[2]) / 3.0 + *j
        })
        .collect();
    for (p, fast) in near.iter().zip(solid.contains_many(&near)) {
        let exact = solid.winding_number_exact(*p);
        // Exactly on the surface |w| is 1/2 and either answer is right.
        if (exact.abs() - 0.5).abs() > 1e-6 {
            assert_eq!(fast, exact.abs() > 0.5, "{name}: {p}: exact w = {exact}");
        }
    }
    // A shadow ray from far outside towards the centre is blocked; one pointing away is not.
    assert!(
        solid.any_hit(DVec3::new(0.0, 0.0, -100.0), DVec3::Z, 200.0),
        "{name}"
    );
    assert!(
        !solid.any_hit(DVec3::new(0.0, 0.0, -100.0), -DVec3::Z, 200.0),
        "{name}"
    );
    solid
}

#[test]
fn closed_test_meshes_pass_validation() {
    for (name, faces) in [
        ("spot", 5856),
        ("rocker-arm", 20088),
        ("fandisk", 12946),
        ("cheburashka", 13334),
        ("homer", 12000),
        ("nefertiti", 99938),
    ] {
        let Some(path) = translucent_tests::test_mesh(&format!("{name}.obj")) else {
            continue;
        };
        let mut mesh = TriMesh::load_obj(&path).unwrap();
        let report = mesh.validate(&ValidateOptions::default()).unwrap();
        assert_eq!(report.faces, faces, "{name}");
        assert_eq!(
            (
                report.boundary_edges,
                report.non_manifold_edges,
                report.inconsistent_edges
            ),
            (0, 0, 0),
            "{name}"
        );
        assert_eq!(
            (report.components, report.degenerate_faces_dropped),
            (1, 0),
            "{name}"
        );
        assert!(!report.forced && !report.inverted, "{name}");
        assert!(
            report.summary().contains("closed"),
            "{name}: {}",
            report.summary()
        );
        assert_eq!(mesh.normals.len(), mesh.positions.len());
        assert!(
            mesh.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-9),
            "{name}: normals"
        );
        check_solid(name, &mesh, 60);
    }
}

#[test]
fn stanford_bunny_with_holes_passes_and_its_holes_are_bridged() {
    let Some(path) = translucent_tests::test_mesh("stanford-bunny.obj") else {
        return;
    };
    let mut mesh = TriMesh::load_obj(&path).unwrap();
    let report = mesh.validate(&ValidateOptions::default()).unwrap();
    assert_eq!(
        (
            report.faces,
            report.boundary_edges,
            report.non_manifold_edges
        ),
        (69451, 223, 0)
    );
    assert!(
        (report.boundary_ratio - 1.42).abs() < 0.005,
        "{}",
        report.boundary_ratio
    );
    assert!(
        !report.forced && report.summary().contains("bridged"),
        "{}",
        report.summary()
    );
    let solid = check_solid("stanford-bunny", &mesh, 150);
    // Points just above each hole (the holes are in the base, the lowest part of the bunny): the
    // winding number stays near 1 inside across the hole's plane, so a point a little inside the
    // rim's centre is inside.
    let (lo, _) = solid.bounds();
    let base: Vec<DVec3> = solid
        .mesh()
        .positions
        .iter()
        .filter(|p| p.y < lo.y + 2.0)
        .copied()
        .collect();
    assert!(!base.is_empty());
    let centre = base.iter().sum::<DVec3>() / base.len() as f64;
    let above = centre + DVec3::Y * 3.0;
    assert!(solid.contains(above), "w = {}", solid.winding_number(above));
    assert!(!solid.contains(centre - DVec3::Y * 3.0));
}

#[test]
fn open_teapot_is_refused_unless_forced() {
    let Some(path) = translucent_tests::test_mesh("teapot.obj") else {
        return;
    };
    let mut mesh = TriMesh::load_obj(&path).unwrap();
    let err = mesh.validate(&ValidateOptions::default()).unwrap_err();
    let MeshError::OpenSurface {
        boundary_edges,
        ratio,
        limit,
    } = err
    else {
        panic!("{err:?}")
    };
    assert_eq!(boundary_edges, 1036);
    assert!((ratio - 19.1).abs() < 0.05 && limit == 5.0, "{ratio}");
    let message = err.to_string();
    assert!(
        message.contains("open surface") && message.contains("force"),
        "{message}"
    );
    let forced = ValidateOptions {
        force_open: true,
        ..Default::default()
    };
    let report = mesh.validate(&forced).unwrap();
    assert!(
        report.forced && report.summary().contains("FORCED"),
        "{}",
        report.summary()
    );
    // Forced, the soup still classifies like its brute-force winding number.
    check_solid("teapot", &mesh, 150);
}

#[test]
fn suzanne_with_a_non_manifold_edge_is_refused_unless_forced() {
    let Some(path) = translucent_tests::test_mesh("suzanne.obj") else {
        return;
    };
    let mut mesh = TriMesh::load_obj(&path).unwrap();
    // Forcing the open parts does not force the non-manifold edge.
    let forced_open = ValidateOptions {
        force_open: true,
        ..Default::default()
    };
    let err = mesh.validate(&forced_open).unwrap_err();
    let MeshError::NonManifoldEdge { a, b, faces, .. } = err else {
        panic!("{err:?}")
    };
    assert!(faces > 2 && a != b);
    assert!(err.to_string().contains("non-manifold edge"), "{err}");
    let report = mesh.validate(&ValidateOptions::forced()).unwrap();
    assert!(
        report.forced && report.non_manifold_edges == 1,
        "{report:?}"
    );
    // Forced, it is a solid with an inside: the middle of the head.
    let (mesh, _) = mesh.normalized(50.0).unwrap();
    let solid = MeshSolid::new(mesh).unwrap();
    let w = solid.winding_number(DVec3::ZERO);
    assert!(solid.contains(DVec3::ZERO), "w = {w}");
    assert!(!solid.contains(DVec3::splat(30.0)));
}
