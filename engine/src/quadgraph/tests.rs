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
            let (c, _) = level.face_frame(s);
            assert!((p - c).length() <= 2.0 * level.spacing);
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
