//! Invariants of baked QuadGraphs on exact procedural solids.

use glam::DVec3;

use super::graph::{NodeKind, QuadGraph, NO_NODE};
use super::*;
use crate::mesh::shapes::Shape;

fn bake(shape: Shape, resolution: u32, levels: u32) -> (QuadGraph, BakeStats) {
    let params = BakeParams {
        resolution,
        levels,
        ..Default::default()
    };
    QuadGraph::bake(&shape.triangulate(48), &shape, &params, &mut |_| {}).expect("bake")
}

/// The graph invariants of DESIGN section 3 step 5, on every level.
fn check_graph(name: &str, shape: Shape, graph: &QuadGraph) {
    for (l, level) in graph.levels.iter().enumerate() {
        let ni = level.inner_count();
        assert_eq!(level.positions.len(), level.node_count());
        let mut surface_refs = vec![0u32; level.surface_count()];
        for (i, nb) in level.neighbors.iter().enumerate() {
            for (f, &j) in nb.iter().enumerate() {
                assert_ne!(
                    j, NO_NODE,
                    "{name} level {l}: inner node {i} lacks neighbour {f}"
                );
                match level.kind(j) {
                    NodeKind::Inner => assert!(
                        level.neighbors[j as usize].contains(&(i as u32)),
                        "{name}: asymmetric"
                    ),
                    NodeKind::Surface => {
                        let s = j as usize - ni;
                        surface_refs[s] += 1;
                        assert_eq!(
                            level.surface_faces[s],
                            (i as u32, f as u8),
                            "{name}: surface node on wrong face"
                        );
                    }
                }
            }
        }
        assert!(
            surface_refs.iter().all(|&c| c == 1),
            "{name} level {l}: a surface node without exactly 1 neighbour"
        );
        for (s, n) in level.surface_normals.iter().enumerate() {
            let p = level.positions[ni + s];
            assert!(
                p.is_finite() && n.is_finite() && (n.length() - 1.0).abs() < 1e-9,
                "{name}: bad surface node"
            );
            // Every surface node of an exact solid is found on the surface, with the exact normal.
            assert!(
                shape.signed_distance(p).abs() < 1e-6 * level.spacing,
                "{name}: surface node {p} off the surface"
            );
            let (c, face_normal) = level.face_frame(s);
            assert!((p - c).length() <= 2.0 * level.spacing);
            // The surface node lies in front of its inner node, at least half the face's distance.
            let k = level.positions[level.surface_faces[s].0 as usize];
            let (d_sk, d_face) = (face_normal.dot(p - k), face_normal.dot(c - k));
            assert!(
                d_sk >= 0.5 * d_face - 1e-9 * level.spacing,
                "{name}: d_sk {d_sk} vs face {d_face}"
            );
            assert!(
                n.dot(face_normal) > 0.0,
                "{name}: surface normal against its face's outward normal"
            );
        }
        for (i, p) in level.positions[..ni].iter().enumerate() {
            assert!(p.is_finite(), "{name}: inner node {i} not finite");
        }
        // Each tetrahedron has at most one boundary face after the split (paper Fig. 4).
        let mut per_tet = vec![0; ni];
        for &(t, _) in &level.surface_faces {
            per_tet[t as usize] += 1;
        }
        assert!(
            per_tet.iter().all(|&c| c <= 1),
            "{name} level {l}: a tetrahedron with 2+ boundary faces"
        );
    }
}

#[test]
fn sphere_and_box_graphs_keep_the_invariants_and_levels_shrink_by_about_four() {
    let sphere = Shape::Sphere { radius: 10.0 };
    let cube = Shape::Box {
        half_extents: DVec3::new(12.0, 5.0, 9.0),
    };
    for (name, shape) in [("sphere", sphere), ("box", cube)] {
        let (graph, stats) = bake(shape, 24, 3);
        check_graph(name, shape, &graph);
        for w in stats.levels.windows(2) {
            let ratio = w[1].surface_nodes as f64 / w[0].surface_nodes as f64;
            assert!(
                (2.5..6.0).contains(&ratio),
                "{name}: surface nodes grow {ratio}x per level"
            );
        }
        eprintln!(
            "{name}: {:#?}",
            stats
                .levels
                .iter()
                .map(|l| (
                    l.surface_nodes,
                    l.inner_nodes,
                    l.min_dihedral_deg,
                    l.max_dihedral_deg,
                    l.locality,
                    l.random_locality
                ))
                .collect::<Vec<_>>()
        );
        assert!(
            stats.min_dihedral_deg >= 10.7 - 1e-9
                || stats.levels.iter().any(|l| l.tetrahedra_split > 0)
        );
    }
}

/// Checks one set of Shepard weights: normalized, finite, non-empty, exact on constants, and within
/// `tol` of a linear field (returned: the largest linear error).
fn check_weights<const B: usize>(
    what: &str,
    ids: &[u32; B],
    w: &[f64; B],
    x: DVec3,
    points: impl Fn(u32) -> DVec3,
) -> f64 {
    assert!(ids[0] != NO_NODE, "{what}: empty weight set");
    let sum: f64 = w.iter().sum();
    assert!((sum - 1.0).abs() < 1e-12, "{what}: weights sum to {sum}");
    assert!(w.iter().all(|&v| v.is_finite() && v >= 0.0));
    let constant: f64 = ids
        .iter()
        .zip(w)
        .filter(|(&i, _)| i != NO_NODE)
        .map(|(_, &v)| 3.5 * v)
        .sum();
    assert!(
        (constant - 3.5).abs() < 1e-12,
        "{what}: constant not reproduced"
    );
    let grad = DVec3::new(0.3, -0.5, 0.8).normalize();
    let interp: f64 = ids
        .iter()
        .zip(w)
        .filter(|(&i, _)| i != NO_NODE)
        .map(|(&i, &v)| v * grad.dot(points(i)))
        .sum();
    (interp - grad.dot(x)).abs()
}

#[test]
fn level_links_and_shading_weights_are_normalized_and_near_linear_exact() {
    let shape = Shape::Torus {
        major: 10.0,
        minor: 4.0,
    };
    let (graph, _) = bake(shape, 32, 3);
    for l in 1..graph.levels.len() {
        let (fine, coarse) = (&graph.levels[l], &graph.levels[l - 1]);
        let links = fine
            .from_coarser
            .as_ref()
            .expect("links on every finer level");
        let (mut worst_inner, mut worst_surface, mut sum_err) = (0.0f64, 0.0f64, 0.0);
        for node in 0..fine.node_count() {
            let x = fine.positions[node];
            let err = check_weights(
                "level link",
                &links.links[node],
                &links.weights[node],
                x,
                |j| coarse.positions[j as usize],
            );
            for &j in links.links[node].iter().filter(|&&j| j != NO_NODE) {
                // Inner nodes link to inner nodes and surface nodes to surface nodes.
                assert_eq!(coarse.kind(j), fine.kind(node as u32));
            }
            sum_err += err;
            if node < fine.inner_count() {
                worst_inner = worst_inner.max(err);
            } else {
                worst_surface = worst_surface.max(err);
            }
        }
        let h = coarse.spacing;
        let mean = sum_err / fine.node_count() as f64;
        eprintln!(
            "level {l}: worst inner {:.3} H, surface {:.3} H, mean {:.3} H",
            worst_inner / h,
            worst_surface / h,
            mean / h
        );
        // Shepard weights are a convex combination of points within 2 coarse spacings H, so the
        // error on a unit-gradient linear field is at most 2H. Measured here (coarse levels of 8
        // and 16 cells across): inner nodes at most 0.42 H, surface nodes at most 1.17 H
        // and 1.19 H: one-sided candidates on a tube 2-5 cells wide), mean 0.07 H.
        assert!(
            worst_inner < 0.5 * h,
            "inner linear field error {worst_inner} > 0.5 H"
        );
        assert!(
            worst_surface < 1.25 * h,
            "surface linear field error {worst_surface} > 1.25 H"
        );
        assert!(mean < 0.1 * h, "mean linear error {mean} > 0.1 H");
    }
    let finest = graph.finest();
    let ni = finest.inner_count();
    let mut worst = 0.0f64;
    for (v, (&p, &n)) in graph
        .surface
        .positions
        .iter()
        .zip(&graph.surface.normals)
        .enumerate()
    {
        let (ids, w) = (&graph.shading.links[v], &graph.shading.weights[v]);
        worst = worst.max(check_weights("shading", ids, w, p, |s| {
            finest.positions[ni + s as usize]
        }));
        for &s in ids.iter().filter(|&&s| s != NO_NODE) {
            assert!(
                finest.surface_normals[s as usize].dot(n) > 0.0,
                "shading reaches across the surface"
            );
        }
    }
    eprintln!("shading worst {:.3} h", worst / finest.spacing);
    assert!(worst < 0.75 * finest.spacing);
}

#[test]
fn packing_separates_kinds_in_full_blocks_and_beats_random_locality() {
    let shape = Shape::Sphere { radius: 10.0 };
    let (graph, stats) = bake(shape, 32, 2);
    for (level, s) in graph.levels.iter().zip(&stats.levels) {
        let p = &level.packing;
        let r = p.block;
        assert_eq!(r, 32);
        assert!(p.width % r == 0 && p.height % r == 0 && p.surface_rows % r == 0);
        let mut seen = std::collections::HashSet::new();
        for (node, &[u, v]) in p.texels.iter().enumerate() {
            assert!(u < p.width && v < p.height);
            assert!(seen.insert((u, v)), "two nodes share texel ({u}, {v})");
            let surface_row = v < p.surface_rows;
            assert_eq!(
                surface_row,
                level.kind(node as u32) == NodeKind::Surface,
                "node {node} in the wrong rows"
            );
        }
        let padding = p.texel_nodes().iter().filter(|&&n| n == NO_NODE).count();
        assert_eq!(padding, (p.width * p.height) as usize - level.node_count());
        eprintln!(
            "locality {:.3} vs random {:.3}",
            s.locality, s.random_locality
        );
        assert!(s.locality > 0.5 && s.locality > 3.0 * s.random_locality);
    }
}

fn scratch_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("translucent-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

fn assert_same_graph(a: &QuadGraph, b: &QuadGraph) {
    assert_eq!(a.levels, b.levels);
    assert_eq!(a.shading, b.shading);
    assert_eq!(a.surface.positions, b.surface.positions);
    assert_eq!(a.surface.normals, b.surface.normals);
    assert_eq!(a.surface.indices, b.surface.indices);
}

#[test]
fn cache_round_trips_and_detects_corruption_truncation_version_and_staleness() {
    let shape = Shape::Sphere { radius: 8.0 };
    let surface = shape.triangulate(24);
    let params = BakeParams {
        resolution: 16,
        levels: 2,
        ..Default::default()
    };
    let dir = scratch_dir("cache");
    let path = dir.join("ball.qgraph");
    let (baked, _, outcome) =
        cache::bake_cached(&path, &surface, &shape, &params, &mut |_| {}).unwrap();
    assert!(matches!(outcome, cache::CacheOutcome::Baked));
    let (loaded, _, outcome) =
        cache::bake_cached(&path, &surface, &shape, &params, &mut |_| {}).unwrap();
    assert!(matches!(outcome, cache::CacheOutcome::Loaded));
    assert_same_graph(&baked, &loaded);
    let good = std::fs::read(&path).unwrap();
    let key = cache::cache_key(&surface, &params);

    let mut flipped = good.clone();
    let mid = flipped.len() / 2;
    flipped[mid] ^= 0x10;
    std::fs::write(&path, &flipped).unwrap();
    assert!(matches!(
        QuadGraph::load(&path, Some(key)),
        Err(BakeError::CacheChecksum { .. })
    ));

    std::fs::write(&path, &good[..good.len() - 100]).unwrap();
    assert!(matches!(
        QuadGraph::load(&path, Some(key)),
        Err(BakeError::CacheTruncated { .. })
    ));
    std::fs::write(&path, &good[..5]).unwrap();
    assert!(matches!(
        QuadGraph::load(&path, Some(key)),
        Err(BakeError::CacheTruncated { .. })
    ));

    let mut version = good.clone();
    version[8] = version[8].wrapping_add(1);
    std::fs::write(&path, &version).unwrap();
    assert!(matches!(
        QuadGraph::load(&path, Some(key)),
        Err(BakeError::CacheVersion { .. })
    ));

    std::fs::write(&path, b"not a cache at all").unwrap();
    assert!(matches!(
        QuadGraph::load(&path, Some(key)),
        Err(BakeError::CacheMagic { .. })
    ));

    std::fs::write(&path, &good).unwrap();
    let other = BakeParams { k: 0.25, ..params };
    assert!(matches!(
        QuadGraph::load(&path, Some(cache::cache_key(&surface, &other))),
        Err(BakeError::CacheStale { .. })
    ));

    // A corrupt file is rebuilt and replaced by a valid one; no temporary file is left behind.
    std::fs::write(&path, &flipped).unwrap();
    let (rebuilt, _, outcome) =
        cache::bake_cached(&path, &surface, &shape, &params, &mut |_| {}).unwrap();
    assert!(
        matches!(
            outcome,
            cache::CacheOutcome::Rebuilt(BakeError::CacheChecksum { .. })
        ),
        "{outcome:?}"
    );
    assert_same_graph(&baked, &rebuilt);
    assert_eq!(
        std::fs::read(&path).unwrap(),
        good,
        "the bake is deterministic and the file was rewritten"
    );
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "left over: {names:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn export_writes_vtk_csv_and_obj_that_match_the_graph() {
    let shape = Shape::Box {
        half_extents: DVec3::new(6.0, 4.0, 5.0),
    };
    let (graph, _) = bake(shape, 12, 2);
    let dir = scratch_dir("export");
    let files = export::export(&graph, &dir).unwrap();
    assert_eq!(files.len(), 5);
    for (l, level) in graph.levels.iter().enumerate() {
        let csv = std::fs::read_to_string(dir.join(format!("nodes-{l}.csv"))).unwrap();
        let mut lines = csv.lines();
        assert_eq!(lines.next(), Some("id,kind,x,y,z,n0,n1,n2,n3"));
        let rows: Vec<&str> = lines.collect();
        assert_eq!(rows.len(), level.node_count());
        assert_eq!(
            rows.iter()
                .filter(|r| r.split(',').nth(1) == Some("surface"))
                .count(),
            level.surface_count()
        );
        let vtk = std::fs::read_to_string(dir.join(format!("tets-{l}.vtk"))).unwrap();
        assert!(vtk.starts_with("# vtk DataFile Version"));
        assert!(vtk.contains(&format!(
            "CELLS {} {}",
            level.inner_count(),
            5 * level.inner_count()
        )));
        assert!(vtk.contains(&format!("POINTS {} double", level.tets.vertices.len())));
    }
    let obj = std::fs::read_to_string(dir.join("surface.obj")).unwrap();
    assert_eq!(
        obj.lines().filter(|l| l.starts_with("v ")).count(),
        graph.surface.positions.len()
    );
    assert_eq!(
        obj.lines().filter(|l| l.starts_with("f ")).count(),
        graph.surface.indices.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_parameters_are_typed_errors() {
    let shape = Shape::Sphere { radius: 5.0 };
    let surface = shape.triangulate(8);
    for params in [
        BakeParams {
            levels: 0,
            ..Default::default()
        },
        BakeParams {
            resolution: 8,
            levels: 3,
            ..Default::default()
        },
        BakeParams {
            k: f64::NAN,
            ..Default::default()
        },
        BakeParams {
            k: -1.0,
            ..Default::default()
        },
        BakeParams {
            block: 0,
            ..Default::default()
        },
        BakeParams {
            sample_depth: f64::NAN,
            ..Default::default()
        },
        BakeParams {
            sample_depth: 0.0,
            ..Default::default()
        },
    ] {
        let r = QuadGraph::bake(&surface, &shape, &params, &mut |_| {});
        assert!(matches!(r, Err(BakeError::Parameter { .. })), "{params:?}");
    }
    let empty = crate::mesh::TriMesh::default();
    assert!(matches!(
        QuadGraph::bake(&empty, &shape, &BakeParams::default(), &mut |_| {}),
        Err(BakeError::Invalid(_))
    ));
}

#[test]
fn relaxation_keeps_inner_nodes_inside_their_tetrahedra() {
    let shape = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 16,
        levels: 1,
        relax: true,
        ..Default::default()
    };
    let (graph, _) = QuadGraph::bake(&shape.triangulate(32), &shape, &params, &mut |_| {}).unwrap();
    let level = graph.finest();
    let mut moved = 0;
    for i in 0..level.inner_count() {
        let [a, b, c, d] = level.tets.tets[i].map(|v| level.tets.vertices[v as usize]);
        let p = level.positions[i];
        let vol = |a: DVec3, b: DVec3, c: DVec3, d: DVec3| (b - a).dot((c - a).cross(d - a));
        let total = vol(a, b, c, d);
        let bary = [
            vol(p, b, c, d),
            vol(a, p, c, d),
            vol(a, b, p, d),
            vol(a, b, c, p),
        ]
        .map(|v| v / total);
        assert!(
            bary.iter().all(|&x| x >= 0.1 - 1e-9),
            "node {i} left its cell: {bary:?}"
        );
        if (p - (a + b + c + d) / 4.0).length() > 1e-9 {
            moved += 1;
        }
    }
    assert!(
        moved > level.inner_count() / 2,
        "relaxation moved only {moved} nodes"
    );
}

#[test]
fn tet_faces_point_out_of_positively_oriented_tetrahedra() {
    let v = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
    assert!((v[1] - v[0]).dot((v[2] - v[0]).cross(v[3] - v[0])) > 0.0);
    let centroid = v.iter().sum::<DVec3>() / 4.0;
    for (f, face) in super::graph::TET_FACES.iter().enumerate() {
        assert!(!face.contains(&f), "face {f} must be opposite vertex {f}");
        let [a, b, c] = face.map(|i| v[i]);
        let n = (b - a).cross(c - a);
        assert!(
            n.dot((a + b + c) / 3.0 - centroid) > 0.0,
            "face {f} points inward"
        );
    }
}

#[test]
fn tiny_huge_and_too_thin_solids_give_finite_graphs_or_typed_errors() {
    // Scale invariance: the same sphere at 1 micrometre and at 100 metres.
    for radius in [1e-3, 1e5] {
        let shape = Shape::Sphere { radius };
        let params = BakeParams {
            resolution: 12,
            levels: 2,
            ..Default::default()
        };
        let (graph, stats) =
            QuadGraph::bake(&shape.triangulate(24), &shape, &params, &mut |_| {}).unwrap();
        check_graph(&format!("sphere r={radius}"), shape, &graph);
        for level in &graph.levels {
            let links = level
                .from_coarser
                .iter()
                .flat_map(|l| l.weights.iter().flatten());
            assert!(links
                .chain(graph.shading.weights.iter().flatten())
                .all(|w| w.is_finite()));
        }
        assert!(stats.bytes_per_node.is_finite() && stats.min_dihedral_deg > 10.0);
    }
    // A sheet much thinner than the lattice has no tetrahedra: a typed error, not a panic.
    let sheet = Shape::Box {
        half_extents: DVec3::new(20.0, 0.01, 20.0),
    };
    let r = QuadGraph::bake(
        &sheet.triangulate(8),
        &sheet,
        &BakeParams::default(),
        &mut |_| {},
    );
    assert!(
        matches!(r, Err(BakeError::Empty { .. })),
        "{:?}",
        r.map(|_| ())
    );
}

#[test]
fn bake_mesh_uses_the_mesh_as_solid_and_linear_indices_address_texels() {
    let shape = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 12,
        levels: 2,
        ..Default::default()
    };
    let (graph, _) = QuadGraph::bake_mesh(&shape.triangulate(32), &params).unwrap();
    let (exact, _) = QuadGraph::bake(&shape.triangulate(32), &shape, &params, &mut |_| {}).unwrap();
    // Same lattice; the stuffing differs where the faceted sphere (chords 0.05 mm inside) does.
    let (a, b) = (
        graph.finest().inner_count() as f64,
        exact.finest().inner_count() as f64,
    );
    assert!((a - b).abs() < 0.1 * b, "{a} vs {b} inner nodes");
    let finest = graph.finest();
    for s in 0..finest.surface_count() {
        let r = finest.positions[finest.inner_count() + s].length();
        assert!(
            (9.94..=10.0 + 1e-9).contains(&r),
            "surface node at radius {r}, not on the mesh"
        );
    }
    for level in &graph.levels {
        let p = &level.packing;
        let texels = p.texel_nodes();
        for node in 0..level.node_count() as u32 {
            assert_eq!(texels[p.linear_index(node) as usize], node);
        }
        assert_eq!(p.linear_index(NO_NODE), NO_NODE);
    }
}

#[test]
fn real_mesh_surface_nodes_stay_in_front_of_their_inner_nodes() {
    use crate::mesh::{MeshSolid, TriMesh, ValidateOptions};
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/meshes/spot.obj");
    let dir = std::env::var_os("TRANSLUCENT_MESH_DIR").map(std::path::PathBuf::from);
    let path = dir.map_or(path, |d| d.join("spot.obj"));
    if !path.is_file() {
        assert!(
            std::env::var_os("CI").is_none(),
            "test mesh {} missing",
            path.display()
        );
        eprintln!(
            "skipped: test mesh {} not found (set TRANSLUCENT_MESH_DIR)",
            path.display()
        );
        return;
    }
    let mut mesh = TriMesh::load_obj(&path).unwrap();
    mesh.validate(&ValidateOptions::default()).unwrap();
    let (mut mesh, _) = mesh.normalized(50.0).unwrap();
    mesh.compute_normals();
    let solid = MeshSolid::new(mesh.clone()).unwrap();
    let params = BakeParams {
        resolution: 32,
        levels: 1,
        ..Default::default()
    };
    let (g, stats) = QuadGraph::bake(&mesh, &solid, &params, &mut |_| {}).unwrap();
    let l = g.finest();
    for s in 0..l.surface_count() {
        let (c, n) = l.face_frame(s);
        let k = l.positions[l.surface_faces[s].0 as usize];
        let p = l.positions[l.inner_count() + s];
        let (d_sk, d_face) = (n.dot(p - k), n.dot(c - k));
        assert!(
            d_sk >= 0.5 * d_face - 1e-9,
            "surface node {s}: d_sk {d_sk}, face at {d_face}"
        );
    }
    // Spot is closed: every ray meets the surface (a few clamped in front of their inner node).
    let level = &stats.levels[0];
    let (hit, clamped) = (level.surface_nodes_on_surface, level.surface_nodes_clamped);
    assert_eq!(
        hit + clamped,
        l.surface_count(),
        "surface nodes left at their face centroid"
    );
    assert!(
        clamped * 20 < l.surface_count(),
        "{clamped} clamped of {}",
        l.surface_count()
    );
}

/// A box's display mesh is split at its edges: 24 vertices (4 per face) with the faces' axis
/// normals, and each vertex shades from surface nodes on its own face only (a lit face's corner
/// takes nothing from the nodes under a dark neighbouring face; with one vertex per corner, its
/// averaged normal took the nodes of all three faces).
#[test]
fn a_box_display_mesh_has_a_vertex_per_face_shading_from_its_own_face() {
    let shape = Shape::Box {
        half_extents: DVec3::new(10.0, 6.0, 4.0),
    };
    let surface = crate::mesh::split::corner_box(DVec3::new(10.0, 6.0, 4.0));
    assert_eq!(surface.positions.len(), 8);
    let params = BakeParams {
        resolution: 16,
        levels: 1,
        ..Default::default()
    };
    let (graph, _) = QuadGraph::bake(&surface, &shape, &params, &mut |_| {}).expect("bake");
    let display = &graph.surface;
    assert_eq!(display.positions.len(), 24);
    assert_eq!(graph.shading.links.len(), 24);
    assert_eq!(graph.samples.depth.len(), 24);
    let finest = graph.finest();
    for (v, n) in display.normals.iter().enumerate() {
        assert_eq!(
            n.abs().max_element(),
            1.0,
            "vertex {v}: normal {n} is not an axis"
        );
        let links = graph.shading.links[v];
        let weights = graph.shading.weights[v];
        assert!(weights.iter().sum::<f64>() > 0.0, "vertex {v}: no weight");
        for (&s, &w) in links.iter().zip(&weights) {
            if s == NO_NODE || w == 0.0 {
                continue;
            }
            let m = finest.surface_normals[s as usize];
            assert!(
                m.dot(*n) > 0.99,
                "vertex {v} (normal {n}) takes weight {w} from node {s} with normal {m}"
            );
        }
    }
}

#[test]
fn the_sample_depth_is_a_bake_parameter_and_part_of_the_cache_key() {
    // A sphere of radius 10 mm on 12 cells (spacing 1.67 mm): no wall is thin enough to bound the
    // depth, so every vertex's sample lies `sample_depth` finest spacings below it.
    let shape = Shape::Sphere { radius: 10.0 };
    let surface = shape.triangulate(16);
    let mut keys = Vec::new();
    for sample_depth in [surface_samples::DEPTH_SPACINGS, 1.0] {
        let params = BakeParams {
            resolution: 12,
            levels: 1,
            sample_depth,
            ..Default::default()
        };
        let (graph, _) = QuadGraph::bake(&surface, &shape, &params, &mut |_| {}).expect("bake");
        let h = graph.finest().spacing;
        let depths = &graph.samples.depth;
        assert!(!depths.is_empty());
        for (v, d) in depths.iter().enumerate() {
            assert!(
                (d / h - sample_depth).abs() < 1e-9,
                "vertex {v}: depth {d} mm, {} spacings, asked {sample_depth}",
                d / h
            );
        }
        keys.push(cache::cache_key(&surface, &params));
    }
    assert_ne!(keys[0], keys[1], "the cache key ignores the sample depth");
}
