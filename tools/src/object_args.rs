//! The object options shared by `bake` and `render` (DESIGN section 8): a mesh or a procedural
//! shape, normalized to `--size-mm`, and the bake parameters. Loading validates the mesh
//! (`--force` accepts open or non-manifold input as the solid its winding number describes).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use glam::DVec3;
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
use translucent::quadgraph::BakeParams;

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
    /// Number of levels (coarsest first; each finer level has about 4x the surface nodes).
    #[arg(long, default_value_t = BakeParams::default().levels)]
    pub levels: u32,
    /// Lattice cells across the longest side at the finest level.
    #[arg(long, default_value_t = BakeParams::default().resolution)]
    pub resolution: u32,
    /// Relax inner node positions (for the `paper` scheme only).
    #[arg(long)]
    pub relax: bool,
    /// Accept meshes that fail validation (open sheets, non-manifold edges) as the solid their
    /// generalized winding number describes.
    #[arg(long)]
    pub force: bool,
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
}

impl Object {
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
    pub fn bake_params(&self) -> BakeParams {
        BakeParams {
            resolution: self.resolution,
            k: self.k,
            levels: self.levels,
            relax: self.relax,
            ..Default::default()
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
                let s = shape_by_name(shape, self.size_mm)?;
                Ok(Object {
                    name: format!("shape-{shape}"),
                    surface: s.triangulate(96),
                    solid: Box::new(s),
                    validation: None,
                    boundary_edges: 0,
                })
            }
            (None, None) => anyhow::bail!("give --mesh FILE.obj or --shape NAME"),
        }
    }

    fn load_mesh(&self, path: &Path) -> anyhow::Result<Object> {
        let mut mesh = TriMesh::load_obj(path)?;
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
            surface,
            solid: Box::new(solid),
            validation: Some(report.summary()),
            boundary_edges: report.boundary_edges,
        })
    }
}
