//! Guarantees of the tetrahedralization, checked on exact implicit solids.

use std::collections::HashMap;

use glam::DVec3;

use super::*;
use crate::mesh::shapes::Shape;

/// A solid given by an exact signed distance (negative inside): the test's own oracle, independent
/// of the mesh module's implementation of [`Solid`].
pub(crate) struct SdfSolid<F: Fn(DVec3) -> f64 + Sync> {
    pub sdf: F,
    pub bounds: (DVec3, DVec3),
}

impl<F: Fn(DVec3) -> f64 + Sync> Solid for SdfSolid<F> {
    fn contains(&self, p: DVec3) -> bool {
        (self.sdf)(p) < 0.0
    }
    fn ray_hit(&self, origin: DVec3, dir: DVec3, t_max: f64) -> Option<(f64, DVec3)> {
        // March in steps small against the features, then bisect the first sign change.
        let steps = 256;
        let inside0 = self.contains(origin);
        let mut t0 = 0.0;
        for i in 1..=steps {
            let t1 = t_max * i as f64 / steps as f64;
            if self.contains(origin + dir * t1) != inside0 {
                let (mut a, mut b) = (t0, t1);
                for _ in 0..50 {
                    let m = 0.5 * (a + b);
                    if self.contains(origin + dir * m) == inside0 {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                let p = origin + dir * b;
                let e = 1e-6;
                let g = DVec3::new(
                    (self.sdf)(p + DVec3::X * e) - (self.sdf)(p - DVec3::X * e),
                    (self.sdf)(p + DVec3::Y * e) - (self.sdf)(p - DVec3::Y * e),
                    (self.sdf)(p + DVec3::Z * e) - (self.sdf)(p - DVec3::Z * e),
                );
                return Some((b, g.normalize()));
            }
            t0 = t1;
        }
        None
    }
    fn bounds(&self) -> (DVec3, DVec3) {
        self.bounds
    }
}

pub(crate) fn sphere(radius: f64, centre: DVec3) -> SdfSolid<impl Fn(DVec3) -> f64 + Sync> {
    SdfSolid {
        sdf: move |p: DVec3| (p - centre).length() - radius,
        bounds: (centre - radius, centre + radius),
    }
}

pub(crate) fn torus(major: f64, minor: f64) -> SdfSolid<impl Fn(DVec3) -> f64 + Sync> {
    let shape = Shape::Torus { major, minor };
    let r = major + minor;
    SdfSolid {
        sdf: move |p| shape.signed_distance(p),
        bounds: (DVec3::new(-r, -minor, -r), DVec3::new(r, minor, r)),
    }
}

/// Every face is shared by at most two tetrahedra; returns the boundary faces (shared by one).
pub(crate) fn boundary_faces(mesh: &TetMesh) -> Vec<[u32; 3]> {
    let mut count: HashMap<[u32; 3], (u32, [u32; 3])> = HashMap::new();
    for t in &mesh.tets {
        for f in crate::quadgraph::graph::TET_FACES {
            let face = f.map(|l| t[l]);
            let mut key = face;
            key.sort_unstable();
            let e = count.entry(key).or_insert((0, face));
            e.0 += 1;
        }
    }
    assert!(
        count.values().all(|(n, _)| *n <= 2),
        "a face is shared by more than two tetrahedra"
    );
    count
        .values()
        .filter(|(n, _)| *n == 1)
        .map(|(_, f)| *f)
        .collect()
}

fn check_mesh(
    name: &str,
    solid: &dyn Solid,
    sdf: &dyn Fn(DVec3) -> f64,
    mesh: &TetMesh,
    spacing: f64,
) {
    assert!(!mesh.tets.is_empty(), "{name}: empty mesh");
    for t in &mesh.tets {
        let [a, b, c, d] = t.map(|v| mesh.vertices[v as usize]);
        let v = signed_volume(a, b, c, d);
        assert!(
            v > 1e-9 * spacing.powi(3),
            "{name}: tetrahedron {t:?} has volume {v}"
        );
        let centroid = (a + b + c + d) / 4.0;
        // Strictly inside, on the torus's saddle-shaped inner side too.
        assert!(
            sdf(centroid) < 0.0,
            "{name}: centroid {centroid} outside ({})",
            sdf(centroid)
        );
        assert!(
            solid.contains(centroid) || sdf(centroid) > -1e-9,
            "{name}: oracle disagrees"
        );
    }
    for f in boundary_faces(mesh) {
        for v in f {
            let d = sdf(mesh.vertices[v as usize]).abs();
            assert!(
                d <= spacing,
                "{name}: boundary vertex {d} mm from the surface (spacing {spacing})"
            );
        }
    }
}

#[test]
fn uniform_stuffing_keeps_the_papers_dihedral_bounds_and_a_valid_mesh() {
    // Off-lattice centres and radii so that cut points land everywhere along the edges.
    let mut lo: f64 = 180.0;
    let mut hi: f64 = 0.0;
    for (i, &(r, c)) in [
        (7.3, DVec3::new(0.13, 0.41, -0.27)),
        (9.1, DVec3::new(-0.31, 0.07, 0.5)),
        (5.55, DVec3::ZERO),
    ]
    .iter()
    .enumerate()
    {
        let solid = sphere(r, c);
        let surface = Shape::Sphere { radius: r }.triangulate(48);
        let surface = TriMesh {
            positions: surface.positions.iter().map(|p| *p + c).collect(),
            ..surface
        };
        let params = TetParams {
            spacing: 1.0,
            grading: 0.0,
            ..Default::default()
        };
        let (mesh, stats) = tetrahedralize(&solid, &surface, &params);
        check_mesh(
            &format!("sphere {i}"),
            &solid,
            &|p| (p - c).length() - r,
            &mesh,
            1.0,
        );
        lo = lo.min(stats.min_dihedral_deg);
        hi = hi.max(stats.max_dihedral_deg);
        eprintln!(
            "sphere {i}: {} tets, dihedral [{:.2}, {:.2}]",
            mesh.tets.len(),
            stats.min_dihedral_deg,
            stats.max_dihedral_deg
        );
    }
    assert!(
        lo >= 10.7 && hi <= 164.8,
        "dihedral angles [{lo}, {hi}] outside the paper's [10.7, 164.8]"
    );
}

#[test]
fn graded_stuffing_is_valid_and_coarser_inside() {
    let solid = torus(10.0, 6.3);
    let surface = Shape::Torus {
        major: 10.0,
        minor: 6.3,
    }
    .triangulate(64);
    let shape = Shape::Torus {
        major: 10.0,
        minor: 6.3,
    };
    let uniform = tetrahedralize(
        &solid,
        &surface,
        &TetParams {
            spacing: 0.7,
            grading: 0.0,
            ..Default::default()
        },
    );
    let graded = tetrahedralize(
        &solid,
        &surface,
        &TetParams {
            spacing: 0.7,
            grading: 1.0,
            ..Default::default()
        },
    );
    check_mesh(
        "graded torus",
        &solid,
        &|p| shape.signed_distance(p),
        &graded.0,
        0.7,
    );
    check_mesh(
        "uniform torus",
        &solid,
        &|p| shape.signed_distance(p),
        &uniform.0,
        0.7,
    );
    assert!(
        graded.0.tets.len() * 5 < uniform.0.tets.len() * 4,
        "grading did not coarsen the interior"
    );
    // Tetrahedra near the surface are uniform BCC ones, so the uniform bound holds there.
    assert_eq!(
        graded.1.coarse_cut_tets, 0,
        "the surface left the finest band"
    );
    let (blo, bhi) = graded.1.boundary_dihedral_deg;
    assert!(
        blo >= 10.7 && bhi <= 164.8,
        "graded boundary angles [{blo}, {bhi}]"
    );
    // The graded interior: BCC (60-90 degrees), bisected BCC and transition tetrahedra, whose
    // angles are fixed shapes: [30, 135] degrees (measured, and what the shapes give exactly).
    let (ilo, ihi) = graded.1.interior_dihedral_deg;
    assert!(
        ilo >= 30.0 - 1e-6 && ihi <= 135.0 + 1e-6,
        "graded interior angles [{ilo}, {ihi}]"
    );
    assert!(ilo < 59.0, "no graded tetrahedra were made");
}

#[test]
fn larger_k_gives_fewer_larger_interior_tetrahedra_on_a_big_sphere() {
    let c = DVec3::new(0.21, -0.13, 0.07);
    let solid = sphere(16.0, c);
    let surface = Shape::Sphere { radius: 16.0 }.triangulate(64);
    let surface = TriMesh {
        positions: surface.positions.iter().map(|p| *p + c).collect(),
        ..surface
    };
    let mut previous = usize::MAX;
    for k in [0.0, 0.25, 1.0, 8.0] {
        let params = TetParams {
            spacing: 1.0,
            grading: k,
            ..Default::default()
        };
        let (mesh, stats) = tetrahedralize(&solid, &surface, &params);
        check_mesh(
            &format!("sphere K={k}"),
            &solid,
            &|p| (p - c).length() - 16.0,
            &mesh,
            1.0,
        );
        let largest = mesh
            .tets
            .iter()
            .map(|t| {
                let [a, b, c, d] = t.map(|v| mesh.vertices[v as usize]);
                signed_volume(a, b, c, d)
            })
            .fold(0.0, f64::max);
        eprintln!(
            "K {k}: {} tetrahedra, largest volume {largest:.2} mm^3",
            mesh.tets.len()
        );
        if k <= 1.0 {
            assert!(mesh.tets.len() < previous, "K = {k} did not coarsen");
        } else {
            // The octree's 2:1 balance already lets cells double at every step: K = 1 is the limit.
            assert_eq!(
                mesh.tets.len(),
                previous,
                "K = {k} beyond the balance limit changed the mesh"
            );
        }
        previous = mesh.tets.len();
        // A BCC tetrahedron of the finest lattice has volume h^3 / 12.
        if k >= 1.0 {
            assert!(
                largest > 8.0 / 12.0,
                "K = {k}: no interior tetrahedron 8x the finest"
            );
        }
        assert_eq!(stats.coarse_cut_tets, 0);
        let (lo, hi) = (stats.min_dihedral_deg, stats.max_dihedral_deg);
        assert!(lo >= 10.7 && hi <= 164.8, "K = {k}: angles [{lo}, {hi}]");
    }
}
