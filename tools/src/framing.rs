//! The automatic view of an object (issue 16): which way is up (`--up auto`) and which side is
//! its front (the three-quarter view seen without `--camera`), both decided from the shape.
//!
//! - Up: a large flat base is the bottom. The faces within [`FLAT_TOLERANCE_DEG`] of an axis
//!   and lying in the outermost [`BASE_BAND`] of the object along it are that side's base; the
//!   largest base is down when it is at least [`MIN_BASE_FRACTION`] of the surface and
//!   [`BASE_MAJORITY`] times every other flat area (the other axes' planar faces anywhere, the
//!   opposite side's base). Otherwise +Y, the OBJ convention. A slab, a box or a CAD part with
//!   flat faces all around therefore keeps +Y.
//! - Front: of the two three-quarter views (from +Z's side, the default, and its mirror from -Z's
//!   side), the one on the side of the surface detail: the detail centroid is the mean of the
//!   edge midpoints weighted by the integrated mean curvature `|theta_e| l_e` (dihedral angle
//!   times length). Faces, heads, ears and hands fold the surface more than backs and rumps. The
//!   back view is taken only when that centroid lies [`FRONT_OFFSET`] bounding radii or more
//!   towards -Z, so symmetric shapes (sphere, torus, box) and meshes with their detail spread
//!   around keep the default (+Z is the usual front of an OBJ).
//!
//! ```
//! use translucent::mesh::shapes::Shape;
//! use translucent_tools::framing::{choose_front, choose_up, Side, UpReason};
//!
//! let sphere = Shape::Sphere { radius: 10.0 }.triangulate(32);
//! assert_eq!(choose_up(&sphere).reason, UpReason::NoBase);
//! assert_eq!(choose_front(&sphere).side, Side::Front);
//! ```

use std::collections::HashMap;

use glam::DVec3;
use translucent::mesh::TriMesh;

/// Faces within this angle of an axis are planar along it (scans and CAD bases are flat to well
/// under a degree; a few degrees keep a slightly tilted cut).
pub const FLAT_TOLERANCE_DEG: f64 = 5.0;
/// A base lies in this outermost fraction of the object's extent along its axis.
pub const BASE_BAND: f64 = 0.02;
/// A base covers at least this fraction of the whole surface (nefertiti's cut is 5.9%).
pub const MIN_BASE_FRACTION: f64 = 0.03;
/// A base is this many times larger than any other planar area, so that a box or a CAD part
/// with flat faces on several sides is not turned by a small difference (nefertiti's base is
/// 5.7x the next planar area; fandisk's largest flat face, a CAD part published +Y up, 2.2x).
pub const BASE_MAJORITY: f64 = 3.0;
/// The back three-quarter view is taken when the detail centroid lies this many bounding radii
/// towards -Z (spot's head: 0.042; the other test meshes lie within 0.003 of the centre or
/// towards +Z).
pub const FRONT_OFFSET: f64 = 0.02;

/// The six axis directions with their `--up` names.
pub const AXES: [(&str, DVec3); 6] = [
    ("x", DVec3::X),
    ("-x", DVec3::NEG_X),
    ("y", DVec3::Y),
    ("-y", DVec3::NEG_Y),
    ("z", DVec3::Z),
    ("-z", DVec3::NEG_Z),
];

/// Why an up axis was chosen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum UpReason {
    /// `--up AXIS` given.
    Given,
    /// A procedural shape (built +Y up).
    Shape,
    /// A flat base along the opposite axis: `fraction` of the surface, `majority` times the next
    /// planar area.
    FlatBase { fraction: f64, majority: f64 },
    /// No flat base: the OBJ convention, +Y.
    NoBase,
}

/// The up axis of an object: its `--up` name and why.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpChoice {
    pub axis: &'static str,
    pub reason: UpReason,
}

impl UpChoice {
    /// For the progress line and `--json`: `z (flat base: 7% of the surface, 5.1x the next
    /// planar area)`, `y (no flat base)`, `z (--up)`.
    pub fn describe(&self) -> String {
        match self.reason {
            UpReason::Given => format!("{} (--up)", self.axis),
            UpReason::Shape => format!("{} (procedural shape)", self.axis),
            UpReason::NoBase => format!("{} (auto: no flat base)", self.axis),
            UpReason::FlatBase { fraction, majority } => format!(
                "{} (auto: flat base, {:.1}% of the surface, {majority:.1}x the next planar area)",
                self.axis,
                100.0 * fraction
            ),
        }
    }
}

/// The per-axis planar areas [`choose_up`] decides from (mm^2).
#[derive(Clone, Debug, PartialEq)]
pub struct PlanarAreas {
    pub total: f64,
    /// Base area on each side, in [`AXES`] order (faces in the outermost band along it).
    pub base: [f64; 6],
    /// Planar area along each axis x, y, z anywhere (both orientations).
    pub planar: [f64; 3],
}

fn face(mesh: &TriMesh, tri: &[u32; 3]) -> Option<[DVec3; 3]> {
    let [a, b, c] = tri.map(|i| mesh.positions.get(i as usize).copied());
    Some([a?, b?, c?])
}

/// The planar areas of `mesh` along the axes.
pub fn planar_areas(mesh: &TriMesh) -> PlanarAreas {
    let (lo, hi) = mesh.bounds();
    let cos_flat = FLAT_TOLERANCE_DEG.to_radians().cos();
    let mut areas = PlanarAreas {
        total: 0.0,
        base: [0.0; 6],
        planar: [0.0; 3],
    };
    for tri in &mesh.indices {
        let Some([a, b, c]) = face(mesh, tri) else {
            continue;
        };
        let cross = (b - a).cross(c - a);
        let area = 0.5 * cross.length();
        if !(area > 0.0 && area.is_finite()) {
            continue;
        }
        areas.total += area;
        // why: |n . axis| does not depend on the winding (inside-out meshes are solids too); the
        // side of a base comes from where it lies.
        let n = cross / (2.0 * area);
        let centroid = (a + b + c) / 3.0;
        for (k, (_, dir)) in AXES.iter().enumerate() {
            if n.dot(*dir).abs() < cos_flat {
                continue;
            }
            if k % 2 == 0 {
                areas.planar[k / 2] += area;
            }
            let extent = (hi - lo).dot(dir.abs());
            let outermost = if k % 2 == 0 { hi } else { lo }.dot(*dir);
            if centroid.dot(*dir) >= outermost - BASE_BAND * extent {
                areas.base[k] += area;
            }
        }
    }
    areas
}

/// The opposite of the axis at `k` in [`AXES`].
fn opposite(k: usize) -> usize {
    k ^ 1
}

/// `--up auto`: the axis opposite a large flat base, else +Y (see the module page).
pub fn choose_up(mesh: &TriMesh) -> UpChoice {
    up_from_areas(&planar_areas(mesh))
}

/// [`choose_up`] from measured areas.
pub fn up_from_areas(areas: &PlanarAreas) -> UpChoice {
    let no_base = UpChoice {
        axis: "y",
        reason: UpReason::NoBase,
    };
    let Some((down, &base)) = areas
        .base
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
    else {
        return no_base;
    };
    // why: the total sums finite areas only, so it is never NaN.
    if areas.total <= 0.0 || base < MIN_BASE_FRACTION * areas.total {
        return no_base;
    }
    let other_planar = (0..3)
        .filter(|&a| a != down / 2)
        .map(|a| areas.planar[a])
        .fold(areas.base[opposite(down)], f64::max);
    let majority = base / other_planar.max(f64::MIN_POSITIVE);
    if majority < BASE_MAJORITY {
        return no_base;
    }
    UpChoice {
        axis: AXES[opposite(down)].0,
        reason: UpReason::FlatBase {
            fraction: base / areas.total,
            majority,
        },
    }
}

/// Which three-quarter view the automatic camera takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Side {
    /// From +Z's side (the default).
    Front,
    /// From -Z's side: the mirror of the default view through the object's centre.
    Back,
}

/// The front of an object (+Y up): the side its surface detail is on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrontChoice {
    pub side: Side,
    /// The Z offset of the detail centroid from the bounding-box centre, in bounding radii.
    pub detail_offset: f64,
}

impl FrontChoice {
    /// For the progress line and `--json`: `-z side (surface detail centred 0.042 radii towards
    /// -z)`.
    pub fn describe(&self) -> String {
        let name = match self.side {
            Side::Front => "+z",
            Side::Back => "-z",
        };
        let towards = if self.detail_offset < 0.0 { "-z" } else { "+z" };
        format!(
            "{name} side (surface detail centred {:.3} radii towards {towards})",
            self.detail_offset.abs()
        )
    }
}

/// An edge of [`detail_centroid`]: the first face's normal, the second's once seen, its midpoint
/// and length.
struct Edge {
    first: DVec3,
    second: Option<DVec3>,
    midpoint: DVec3,
    length: f64,
}

/// The detail centroid of `mesh`: the mean of its edge midpoints weighted by `|theta_e| l_e` (the
/// dihedral angle times the length: the integrated mean curvature along the edge), over the
/// edges shared by two faces (positions welded by value, so seams split for texture
/// coordinates still count). `None` for a surface with no folded edge.
pub fn detail_centroid(mesh: &TriMesh) -> Option<DVec3> {
    let mut welded: HashMap<[u64; 3], u32> = HashMap::new();
    let ids: Vec<u32> = mesh
        .positions
        .iter()
        .map(|p| {
            let next = welded.len() as u32;
            *welded.entry(p.to_array().map(f64::to_bits)).or_insert(next)
        })
        .collect();
    let mut edges: HashMap<(u32, u32), Edge> = HashMap::new();
    for tri in &mesh.indices {
        let Some(corners) = face(mesh, tri) else {
            continue;
        };
        let [a, b, c] = corners;
        let n = (b - a).cross(c - a).normalize_or_zero();
        if n == DVec3::ZERO {
            continue;
        }
        for i in 0..3 {
            let (p, q) = (corners[i], corners[(i + 1) % 3]);
            let (u, v) = (ids[tri[i] as usize], ids[tri[(i + 1) % 3] as usize]);
            edges
                .entry((u.min(v), u.max(v)))
                .and_modify(|e| {
                    e.second.get_or_insert(n);
                })
                .or_insert(Edge {
                    first: n,
                    second: None,
                    midpoint: 0.5 * (p + q),
                    length: p.distance(q),
                });
        }
    }
    let (mut sum, mut weight) = (DVec3::ZERO, 0.0);
    for edge in edges.values() {
        let Some(second) = edge.second else { continue };
        // Unsigned: a fold either way (a pair wound apart by an open mesh's patching flips the sign).
        let angle = edge.first.dot(second).abs().clamp(0.0, 1.0).acos();
        sum += edge.midpoint * angle * edge.length;
        weight += angle * edge.length;
    }
    (weight > 0.0 && sum.is_finite()).then(|| sum / weight)
}

/// The unit direction from the object towards the eye of the default three-quarter view
/// (`azimuth` from +Z towards +X, `elevation` up), and of its mirror from -Z's side.
pub fn view_directions(azimuth_deg: f64, elevation_deg: f64) -> [DVec3; 2] {
    let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    let front = DVec3::new(az.sin() * el.cos(), el.sin(), az.cos() * el.cos());
    [front, DVec3::new(-front.x, front.y, -front.z)]
}

/// The side the automatic camera looks from (see the module page), for a mesh already turned
/// +Y up.
pub fn choose_front(mesh: &TriMesh) -> FrontChoice {
    let (lo, hi) = mesh.bounds();
    let (centre, radius) = (0.5 * (lo + hi), 0.5 * (hi - lo).length());
    let detail_offset = match detail_centroid(mesh) {
        Some(c) if radius > 0.0 => (c.z - centre.z) / radius,
        _ => 0.0,
    };
    FrontChoice {
        side: if detail_offset < -FRONT_OFFSET {
            Side::Back
        } else {
            Side::Front
        },
        detail_offset,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use translucent::mesh::shapes::Shape;

    /// A sphere cut flat at `cut` (a unit vector): its vertices beyond 0.4 radii along it are
    /// moved onto that plane.
    fn cut_sphere(cut: DVec3) -> TriMesh {
        let mut mesh = Shape::Sphere { radius: 10.0 }.triangulate(48);
        for p in &mut mesh.positions {
            let along = p.dot(cut);
            if along > 4.0 {
                *p -= (along - 4.0) * cut;
            }
        }
        mesh
    }

    #[test]
    fn a_flat_base_is_down_whichever_axis_it_is_on() {
        for (down, up) in [
            (DVec3::NEG_Z, "z"),
            (DVec3::Z, "-z"),
            (DVec3::NEG_X, "x"),
            (DVec3::NEG_Y, "y"),
            (DVec3::Y, "-y"),
        ] {
            let choice = choose_up(&cut_sphere(down));
            assert_eq!(choice.axis, up, "base towards {down}: {choice:?}");
            assert!(matches!(choice.reason, UpReason::FlatBase { .. }));
        }
    }

    #[test]
    fn no_clear_base_keeps_y() {
        // Round: no planar area at all.
        let sphere = Shape::Sphere { radius: 10.0 }.triangulate(48);
        assert_eq!(choose_up(&sphere).reason, UpReason::NoBase);
        // A box: flat all around, no side a clear majority (its largest faces are on two sides).
        let cube = Shape::Box {
            half_extents: DVec3::new(10.0, 6.0, 8.0),
        }
        .triangulate(16);
        assert_eq!(choose_up(&cube).axis, "y");
        // Cut flat on two opposite sides: a slab, either face could be the bottom.
        let mut slab = cut_sphere(DVec3::Z);
        for p in &mut slab.positions {
            p.z = p.z.max(-4.0);
        }
        assert_eq!(choose_up(&slab).reason, UpReason::NoBase);
    }

    #[test]
    fn symmetric_shapes_keep_the_default_side_and_detail_decides_otherwise() {
        for shape in [
            Shape::Sphere { radius: 10.0 },
            Shape::Torus {
                major: 7.0,
                minor: 3.0,
            },
            Shape::Capsule {
                half_length: 5.0,
                radius: 5.0,
            },
        ] {
            let front = choose_front(&shape.triangulate(48));
            assert_eq!(front.side, Side::Front, "{shape:?}: {front:?}");
        }
        // A sphere with a ridged cap towards -Z: the detail is behind the default view.
        let mut ridged = Shape::Sphere { radius: 10.0 }.triangulate(48);
        for (i, p) in ridged.positions.iter_mut().enumerate() {
            if p.z < -5.0 {
                *p *= if i % 2 == 0 { 1.15 } else { 0.9 };
            }
        }
        let front = choose_front(&ridged);
        assert_eq!(front.side, Side::Back, "{front:?}");
        assert!(front.detail_offset < -FRONT_OFFSET);
    }

    /// Prints the measures for every mesh in ../shared/meshes (a survey for RESULTS, not a
    /// check): `cargo test --release -p translucent-tools --lib framing::tests::survey --
    /// --ignored --nocapture`.
    #[test]
    #[ignore]
    fn survey() {
        let dir = std::env::var("TRANSLUCENT_MESH_DIR").unwrap_or("../shared/meshes".into());
        let mut names: Vec<_> = std::fs::read_dir(&dir)
            .expect("mesh dir")
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "obj"))
            .collect();
        names.sort();
        for path in names {
            let mesh = TriMesh::load_obj(&path).expect("obj");
            let start = std::time::Instant::now();
            let areas = planar_areas(&mesh);
            let up = up_from_areas(&areas);
            let mut turned = mesh.clone();
            crate::object_args::turn_up(&mut turned, up.axis);
            let front = choose_front(&turned);
            let ms = start.elapsed().as_secs_f64() * 1e3;
            println!(
                "{:?} ({} triangles, {ms:.0} ms): up {} | base% {:?} planar% {:?} | front {}",
                path.file_stem().unwrap_or_default(),
                mesh.indices.len(),
                up.describe(),
                areas
                    .base
                    .map(|a| (1000.0 * a / areas.total).round() / 10.0),
                areas
                    .planar
                    .map(|a| (1000.0 * a / areas.total).round() / 10.0),
                front.describe(),
            );
        }
    }
}
