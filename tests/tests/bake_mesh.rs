//! The bake through the public API, as a host runs it: a real mesh (spot) and a procedural torus at
//! low resolution, checked for the graph invariants, tetrahedron quality and containment, weights,
//! packing and the cache (DESIGN section 3).

use glam::DVec3;
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
use translucent::quadgraph::graph::{NodeKind, NO_NODE, TET_FACES};
use translucent::quadgraph::{cache, BakeParams};
use translucent::tet::signed_volume;
use translucent::QuadGraph;

/// Checks every level of `graph` against `solid`; returns the share of surface nodes whose ray met
/// the surface (the rest sit at their face centroid).
fn check_graph(name: &str, graph: &QuadGraph, solid: &dyn Solid) -> f64 {
    let (mut on_surface, mut total) = (0usize, 0usize);
    for (l, level) in graph.levels.iter().enumerate() {
        let ni = level.inner_count();
        let h = level.spacing;
        for (t, tet) in level.tets.tets.iter().enumerate() {
            let [a, b, c, d] = tet.map(|v| level.tets.vertices[v as usize]);
            assert!(
                signed_volume(a, b, c, d) > 0.0,
                "{name} level {l}: tetrahedron {t} not positive"
            );
            // Centroids inside, up to a sliver where the surface curves between cut points.
            let centroid = (a + b + c + d) / 4.0;
            if !solid.contains(centroid) {
                let near = [
                    DVec3::X,
                    DVec3::Y,
                    DVec3::Z,
                    -DVec3::X,
                    -DVec3::Y,
                    -DVec3::Z,
                ]
                .iter()
                .any(|&dir| solid.ray_hit(centroid, dir, 0.25 * h).is_some());
                assert!(
                    near,
                    "{name} level {l}: centroid of tetrahedron {t} outside the solid"
                );
            }
            for (f, &j) in level.neighbors[t].iter().enumerate() {
                assert_ne!(
                    j, NO_NODE,
                    "{name} level {l}: inner node {t} has no neighbour {f}"
                );
                if level.kind(j) == NodeKind::Inner {
                    // Neighbours share the face: the same three vertices.
                    let mut mine = TET_FACES[f].map(|k| tet[k]);
                    mine.sort_unstable();
                    let other = level.tets.tets[j as usize];
                    assert!(
                        mine.iter().all(|v| other.contains(v)),
                        "{name}: neighbours do not share face {f}"
                    );
                }
            }
        }
        let mut refs = vec![0; level.surface_count()];
        for nb in &level.neighbors {
            for &j in nb.iter().filter(|&&j| j as usize >= ni) {
                refs[j as usize - ni] += 1;
            }
        }
        assert!(
            refs.iter().all(|&r| r == 1),
            "{name} level {l}: a surface node without exactly 1 neighbour"
        );
        for s in 0..level.surface_count() {
            let (c, face_normal) = level.face_frame(s);
            let p = level.positions[ni + s];
            let n = level.surface_normals[s];
            assert!(
                p.is_finite() && (n.length() - 1.0).abs() < 1e-9,
                "{name}: bad surface node {s}"
            );
            assert!(
                (p - c).length() <= 2.0 * h + 1e-9,
                "{name}: surface node {s} beyond 2 spacings"
            );
            // The boundary lies within one lattice spacing of the surface.
            assert!(
                (p - c).length() <= h || p == c,
                "{name}: boundary face {s} {} mm from the surface",
                (p - c).length()
            );
            if p != c {
                on_surface += 1;
                assert!(
                    n.dot(face_normal) > 0.0 || solid.contains(c),
                    "{name}: surface normal against the face"
                );
            }
            total += 1;
        }
        for (node, p) in level.positions.iter().enumerate() {
            assert!(p.is_finite(), "{name}: node {node} not finite");
        }
        if let Some(links) = &level.from_coarser {
            for w in &links.weights {
                let sum: f64 = w.iter().sum();
                assert!((sum - 1.0).abs() < 1e-12 && w.iter().all(|x| x.is_finite() && *x >= 0.0));
            }
        }
        let p = &level.packing;
        let texel_nodes = p.texel_nodes();
        assert_eq!(
            texel_nodes.iter().filter(|&&n| n != NO_NODE).count(),
            level.node_count(),
            "{name}: texels collide"
        );
    }
    for w in &graph.shading.weights {
        assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    }
    on_surface as f64 / total as f64
}

#[test]
fn spot_bakes_with_valid_graph_and_round_trips_through_the_cache() {
    let Some(path) = translucent_tests::test_mesh("spot.obj") else {
        return;
    };
    let mut mesh = TriMesh::load_obj(&path).unwrap();
    mesh.validate(&ValidateOptions::default()).unwrap();
    let (mut mesh, _) = mesh.normalized(50.0).unwrap();
    mesh.compute_normals();
    let solid = MeshSolid::new(mesh.clone()).unwrap();
    let params = BakeParams {
        resolution: 20,
        levels: 2,
        ..Default::default()
    };
    let dir = std::env::temp_dir().join(format!("translucent-bake-spot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("spot.qgraph");
    let (graph, stats, _) = cache::bake_cached(&file, &mesh, &solid, &params, &mut |_| {}).unwrap();
    let share = check_graph("spot", &graph, &solid);
    // Spot is closed: every surface node but a handful at the sharpest creases meets the surface.
    assert!(
        share > 0.99,
        "only {share} of the surface nodes lie on the surface"
    );
    assert!(
        stats.min_dihedral_deg > 5.0 && stats.max_dihedral_deg < 175.0,
        "{stats:?}"
    );
    let (loaded, _, outcome) =
        cache::bake_cached(&file, &mesh, &solid, &params, &mut |_| {}).unwrap();
    assert!(matches!(outcome, cache::CacheOutcome::Loaded));
    assert_eq!(loaded.levels, graph.levels);
    assert_eq!(loaded.shading, graph.shading);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn torus_bakes_with_valid_graph_on_every_level() {
    let torus = Shape::Torus {
        major: 12.0,
        minor: 5.0,
    };
    let params = BakeParams {
        resolution: 24,
        levels: 3,
        ..Default::default()
    };
    let (graph, stats) =
        QuadGraph::bake(&torus.triangulate(48), &torus, &params, &mut |_| {}).unwrap();
    let share = check_graph("torus", &graph, &torus);
    assert_eq!(
        share, 1.0,
        "an exact solid puts every surface node on its surface"
    );
    assert!(stats.levels.iter().all(|l| l.coarse_cut_tets == 0));
}

#[test]
fn open_and_non_manifold_meshes_are_refused_with_the_reason() {
    for (name, word) in [
        ("teapot.obj", "open surface"),
        ("suzanne.obj", "non-manifold"),
    ] {
        let Some(path) = translucent_tests::test_mesh(name) else {
            continue;
        };
        let mut mesh = TriMesh::load_obj(&path).unwrap();
        let err = mesh
            .validate(&ValidateOptions::default())
            .unwrap_err()
            .to_string();
        assert!(err.contains(word), "{name}: {err}");
    }
}
