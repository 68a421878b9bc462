//! The object options shared by `bake` and `render` (DESIGN section 8): a mesh or a procedural
//! shape, normalized to `--size-mm`, and the bake parameters. Loading validates the mesh
//! (`--force` accepts open or non-manifold input as the solid its winding number describes).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use glam::DVec3;
use translucent::material::MaterialField;
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
use translucent::quadgraph::resolution::{self, ResolutionChoice};
use translucent::quadgraph::BakeParams;
use translucent::scene::Camera;

use crate::framing::{choose_front, choose_up, FrontChoice, UpChoice, UpReason};

#[derive(clap::Args, Debug, Clone)]
pub struct ObjectArgs {
    /// OBJ file (validated, then normalized to --size-mm).
    #[arg(long, value_name = "FILE.obj", conflicts_with = "shape")]
    pub mesh: Option<PathBuf>,
    /// Procedural shape instead of a mesh: sphere, torus, box, capsule (render's default: torus).
    #[arg(long, value_name = "NAME")]
    pub shape: Option<String>,
    /// Longest side of the object in millimetres (1e-4 to 1e8).
    #[arg(long, default_value_t = 50.0, allow_negative_numbers = true)]
    pub size_mm: f64,
    /// Grading K: 0 keeps the interior lattice uniform; larger values coarsen it faster.
    #[arg(short = 'K', default_value_t = BakeParams::default().k, allow_negative_numbers = true)]
    pub k: f64,
    /// Number of levels (coarsest first; each finer level has about 4x the surface nodes), or
    /// `auto` (the default): 3, one more per halving the coarsest level needs to come to 8
    /// cells across or fewer (`BakeParams::levels_for`: 4 at resolution 48, 5 at 96).
    #[arg(long, value_name = "N|auto", default_value = "auto")]
    pub levels: LevelsArg,
    /// Lattice cells across the longest side at the finest level, or `auto` (the default): the
    /// coarser of what the material needs (its diffusion length and transport mean free path)
    /// and, for a single render, what the image shows (two pixels of the object per node),
    /// within 24..=128 (DESIGN 5.1). The choice is printed and in `--json`.
    #[arg(long, value_name = "N|auto", default_value = "auto")]
    pub resolution: ResolutionArg,
    /// Relax inner node positions (for the `paper` scheme only).
    #[arg(long)]
    pub relax: bool,
    /// The mesh's up axis (auto, x, y, z, -x, -y, -z): the mesh is turned so that this axis
    /// points along +Y, the renderer's up (scans are often z-up). `auto` (the default): the axis
    /// opposite a large flat base (a clear majority of the planar area), else +Y, the OBJ
    /// convention (`framing::choose_up`; the choice is printed and in `--json`). Procedural
    /// shapes are built +Y up.
    #[arg(long, value_name = "AXIS", default_value = "auto", value_parser = ["auto", "x", "y", "z", "-x", "-y", "-z"], allow_hyphen_values = true)]
    pub up: String,
    /// Accept meshes that fail validation (open sheets, non-manifold edges) as the solid their
    /// generalized winding number describes.
    #[arg(long)]
    pub force: bool,
}

/// `--levels N|auto`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LevelsArg {
    Auto,
    Count(u32),
}

impl LevelsArg {
    /// The levels of a bake at `resolution` cells.
    pub fn at(self, resolution: u32) -> u32 {
        match self {
            Self::Auto => BakeParams::levels_for(resolution),
            Self::Count(n) => n,
        }
    }
}

impl std::str::FromStr for LevelsArg {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        if text.eq_ignore_ascii_case("auto") {
            return Ok(Self::Auto);
        }
        text.parse::<u32>()
            .map(Self::Count)
            .map_err(|_| format!("{text:?}: expected a number of levels or auto"))
    }
}

impl std::fmt::Display for LevelsArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Auto => f.write_str("auto"),
            Self::Count(n) => write!(f, "{n}"),
        }
    }
}

/// `--resolution N|auto`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ResolutionArg {
    Auto,
    Cells(u32),
}

impl std::str::FromStr for ResolutionArg {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        if text.eq_ignore_ascii_case("auto") {
            return Ok(Self::Auto);
        }
        text.parse::<u32>()
            .map(Self::Cells)
            .map_err(|_| format!("{text:?}: expected a number of cells or auto"))
    }
}

impl std::fmt::Display for ResolutionArg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Auto => f.write_str("auto"),
            Self::Cells(n) => write!(f, "{n}"),
        }
    }
}

/// The finest lattice resolution a command bakes: given with `--resolution N`, or chosen by
/// `auto` (with what decided it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resolution {
    pub cells: u32,
    /// The finest lattice spacing, mm (longest side / cells).
    pub spacing_mm: f64,
    pub auto: Option<ResolutionChoice>,
}

impl Resolution {
    /// The `--json` entry: `{"resolution", "spacing_mm", "auto": {bound, material_spacing_mm,
    /// image_spacing_mm} | null}` (node counts are added by the caller after the bake).
    pub fn json(&self, finest_nodes: Option<usize>) -> serde_json::Value {
        serde_json::json!({
            "resolution": self.cells,
            "spacing_mm": self.spacing_mm,
            "finest_nodes": finest_nodes,
            "auto": self.auto.map(|c| serde_json::json!({
                "bound": c.bound,
                "material_spacing_mm": c.material_spacing_mm.is_finite().then_some(c.material_spacing_mm),
                "image_spacing_mm": c.image_spacing_mm,
            })),
        })
    }

    /// One line for stderr: `resolution auto: 31 cells (1.6 mm spacing, by the material), N
    /// finest nodes`.
    pub fn line(&self, finest_nodes: usize) -> String {
        match &self.auto {
            Some(c) => format!(
                "resolution auto: {} cells across ({:.3} mm spacing, set by {}), {finest_nodes} nodes on the finest level",
                self.cells, self.spacing_mm, c.bound
            ),
            None => format!(
                "resolution {}: {:.3} mm spacing, {finest_nodes} nodes on the finest level",
                self.cells, self.spacing_mm
            ),
        }
    }
}

/// A loaded, validated and normalized object.
pub struct Object {
    /// File stem or `shape-NAME`.
    pub name: String,
    /// The display surface (normalized, mm).
    pub surface: TriMesh,
    /// The solid the bake fills and shadow rays hit.
    pub solid: Box<dyn Solid>,
    /// The validation summary of a mesh (`None` for shapes).
    pub validation: Option<String>,
    /// Edges used by one face only (0 for shapes and closed meshes).
    pub boundary_edges: usize,
    /// The up axis the surface was turned to +Y from, and why.
    pub up: UpChoice,
    /// The side the automatic three-quarter view looks from.
    pub front: FrontChoice,
}

impl Object {
    /// The automatic camera: the three-quarter view of the surface's bounding sphere from its
    /// front side ([`crate::scene_args::default_camera`]).
    pub fn default_camera(&self, aspect: f64) -> Camera {
        let (centre, radius) = translucent::mesh::bounding_sphere(&self.surface.positions);
        crate::scene_args::default_camera(centre, radius, aspect, self.front.side)
    }

    /// One line for stderr: `view: up z (auto: flat base ...), front +z side (...)`.
    pub fn view_line(&self) -> String {
        format!(
            "view: up {}, seen from the {}",
            self.up.describe(),
            self.front.describe()
        )
    }

    /// The `--json` entry: `{"up": "z (auto: flat base ...)", "front": "-z side (...)"}`.
    pub fn view_json(&self) -> serde_json::Value {
        serde_json::json!({
            "up": self.up.describe(),
            "up_axis": self.up.axis,
            "front": self.front.describe(),
            "front_side": match self.front.side {
                crate::framing::Side::Front => "+z",
                crate::framing::Side::Back => "-z",
            },
        })
    }

    /// The display surface's bounding box (mm).
    pub fn bounds(&self) -> (DVec3, DVec3) {
        self.surface.positions.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        )
    }

    /// A bake error with advice that fits this object: a lattice level with no tetrahedra in an
    /// open surface (a sheet, a single triangle accepted with `--force`) is not cured by a finer
    /// lattice, the surface encloses no volume.
    pub fn explain_bake_error(&self, e: translucent::quadgraph::BakeError) -> anyhow::Error {
        match e {
            translucent::quadgraph::BakeError::Empty { .. } if self.boundary_edges > 0 => {
                anyhow::anyhow!(
                    "{}: an open surface ({} boundary edges) encloses no volume for the bake to fill: translucency needs a closed solid (close the mesh; --resolution and --levels do not help)",
                    self.name,
                    self.boundary_edges
                )
            }
            e => e.into(),
        }
    }
}

/// The unit vector of an `--up` axis name.
fn up_axis(name: &str) -> DVec3 {
    let (sign, axis) = match name.strip_prefix('-') {
        Some(a) => (-1.0, a),
        None => (1.0, name),
    };
    sign * match axis {
        "x" => DVec3::X,
        "z" => DVec3::Z,
        _ => DVec3::Y,
    }
}

/// Turns `mesh` so that the axis `up` points along +Y (a rotation: windings and handedness kept).
pub fn turn_up(mesh: &mut TriMesh, up: &str) {
    let axis = up_axis(up);
    if axis == DVec3::Y {
        return;
    }
    // from_rotation_arc picks a rotation axis orthogonal to both for -y (a half turn).
    let q = glam::DQuat::from_rotation_arc(axis, DVec3::Y);
    for p in mesh.positions.iter_mut().chain(mesh.normals.iter_mut()) {
        *p = q * *p;
    }
}

/// A procedural shape of longest side `size_mm`.
pub fn shape_by_name(name: &str, size_mm: f64) -> anyhow::Result<Shape> {
    Ok(match name {
        "sphere" => Shape::Sphere {
            radius: 0.5 * size_mm,
        },
        "torus" => Shape::Torus {
            major: 0.35 * size_mm,
            minor: 0.15 * size_mm,
        },
        "box" => Shape::Box {
            half_extents: DVec3::new(0.5, 0.3, 0.4) * size_mm,
        },
        "capsule" => Shape::Capsule {
            half_length: 0.25 * size_mm,
            radius: 0.25 * size_mm,
        },
        other => anyhow::bail!("--shape {other:?}: unknown (sphere, torus, box, capsule)"),
    })
}

impl ObjectArgs {
    /// The bake parameters at `resolution` (see [`ObjectArgs::resolution`]).
    pub fn bake_params(&self, resolution: &Resolution) -> BakeParams {
        BakeParams {
            resolution: resolution.cells,
            k: self.k,
            levels: self.levels.at(resolution.cells),
            relax: self.relax,
            ..Default::default()
        }
    }

    /// [`ObjectArgs::bake_params`] with the interior samples' depth for the material `field`
    /// ([`translucent::defaults::sample_depth_for`] at the resolution's spacing): what `render`,
    /// `view` and `bake` bake, so they share cache files.
    pub fn bake_params_for(&self, resolution: &Resolution, field: &MaterialField) -> BakeParams {
        BakeParams {
            sample_depth: translucent::defaults::sample_depth_for(field, resolution.spacing_mm),
            ..self.bake_params(resolution)
        }
    }

    /// `--resolution` for `object`: the given cells, or `auto` from the material `field` and,
    /// for a single render, the `image` it is drawn at (camera, height in pixels; `None` for a
    /// host that zooms, or a bake).
    pub fn resolution(
        &self,
        object: &Object,
        field: &MaterialField,
        image: Option<(&Camera, u32)>,
    ) -> Resolution {
        let (lo, hi) = object.bounds();
        let longest = (hi - lo).max_element();
        match self.resolution {
            ResolutionArg::Cells(cells) => Resolution {
                cells,
                spacing_mm: longest / f64::from(cells.max(1)),
                auto: None,
            },
            ResolutionArg::Auto => {
                let material = resolution::material_spacing_mm(field, lo, hi);
                let image = image.map(|(camera, height)| {
                    resolution::image_spacing_mm(camera, height, 0.5 * (lo + hi))
                });
                let choice = resolution::choose(longest, material, image);
                Resolution {
                    cells: choice.resolution,
                    spacing_mm: choice.spacing_mm,
                    auto: Some(choice),
                }
            }
        }
    }

    /// Loads the mesh (or builds the shape; `default_shape` when neither is given).
    pub fn load(&self, default_shape: Option<&str>) -> anyhow::Result<Object> {
        let range = translucent::mesh::SIZE_RANGE_MM;
        if !range.contains(&self.size_mm) {
            anyhow::bail!(
                "--size-mm {}: must be a number of millimetres from {} to {}",
                self.size_mm,
                range.start(),
                range.end()
            );
        }
        match (&self.mesh, self.shape.as_deref().or(default_shape)) {
            (Some(path), _) => self.load_mesh(path),
            (None, Some(shape)) => {
                if self.up != "y" && self.up != "auto" {
                    anyhow::bail!(
                        "--up {}: applies to --mesh (procedural shapes are built +Y up)",
                        self.up
                    );
                }
                let s = shape_by_name(shape, self.size_mm)?;
                let surface = s.triangulate(96);
                Ok(Object {
                    name: format!("shape-{shape}"),
                    front: choose_front(&surface),
                    surface,
                    solid: Box::new(s),
                    validation: None,
                    boundary_edges: 0,
                    up: UpChoice {
                        axis: "y",
                        reason: UpReason::Shape,
                    },
                })
            }
            (None, None) => anyhow::bail!("give --mesh FILE.obj or --shape NAME"),
        }
    }

    fn load_mesh(&self, path: &Path) -> anyhow::Result<Object> {
        let mut mesh = TriMesh::load_obj(path)?;
        let up = self.up_choice(&mesh);
        turn_up(&mut mesh, up.axis);
        let options = if self.force {
            ValidateOptions::forced()
        } else {
            ValidateOptions::default()
        };
        let report = mesh.validate(&options).with_context(|| {
            format!(
                "{} refused (--force accepts it as a winding-number solid)",
                path.display()
            )
        })?;
        let (mut mesh, _) = mesh.normalized(self.size_mm)?;
        if mesh.normals.len() != mesh.positions.len() {
            mesh.compute_normals();
        }
        let solid = MeshSolid::new(mesh)?;
        // The solid's copy carries the winding made coherent per part: that is what is displayed.
        let surface = solid.mesh().clone();
        let name = path
            .file_stem()
            .map_or("mesh".into(), |s| s.to_string_lossy().into_owned());
        Ok(Object {
            name,
            front: choose_front(&surface),
            surface,
            solid: Box::new(solid),
            validation: Some(report.summary()),
            boundary_edges: report.boundary_edges,
            up,
        })
    }

    /// `--up` for `mesh` as loaded: the given axis, or `auto`'s choice.
    pub fn up_choice(&self, mesh: &TriMesh) -> UpChoice {
        match crate::framing::AXES
            .iter()
            .find(|(name, _)| *name == self.up)
        {
            Some((axis, _)) => UpChoice {
                axis,
                reason: UpReason::Given,
            },
            None => choose_up(mesh),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn up_turns_the_named_axis_to_plus_y_and_keeps_lengths() {
        let mut mesh = TriMesh {
            positions: vec![DVec3::new(1.0, 2.0, 3.0), DVec3::Z],
            normals: vec![DVec3::Z, DVec3::X],
            indices: Vec::new(),
        };
        turn_up(&mut mesh, "z");
        // A rotation, exact to rounding: +Z goes to +Y, lengths are kept.
        assert!((mesh.positions[1] - DVec3::Y).length() < 1e-12);
        assert!((mesh.normals[0] - DVec3::Y).length() < 1e-12);
        assert!((mesh.positions[0].length() - 14f64.sqrt()).abs() < 1e-12);
        for axis in ["x", "-x", "-y", "-z"] {
            let mut m = TriMesh {
                positions: vec![up_axis(axis)],
                normals: Vec::new(),
                indices: Vec::new(),
            };
            turn_up(&mut m, axis);
            assert!((m.positions[0] - DVec3::Y).length() < 1e-12, "{axis}");
        }
        let mut same = mesh.clone();
        turn_up(&mut same, "y");
        assert_eq!(same.positions, mesh.positions);
    }

    #[test]
    fn resolution_parses_auto_and_numbers_only() {
        assert_eq!("auto".parse(), Ok(ResolutionArg::Auto));
        assert_eq!("AUTO".parse(), Ok(ResolutionArg::Auto));
        assert_eq!("32".parse(), Ok(ResolutionArg::Cells(32)));
        for bad in ["", "-3", "fine", "3.5"] {
            assert!(bad.parse::<ResolutionArg>().is_err(), "{bad}");
        }
        assert_eq!(ResolutionArg::Cells(7).to_string(), "7");
    }
}
