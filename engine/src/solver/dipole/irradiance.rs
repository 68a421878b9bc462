//! Per-leaf transmitted irradiance E T_i (the paper's Eq. 5 and section 5.3) on the CPU: lights and
//! environment at each triangle's centroid with its face normal, through
//! [`crate::scene::Scene::irradiance_at`] (q of DESIGN section 2: E max(0, n.l) F_t visibility, plus
//! pi L (1 - F_dr,ext) for a constant environment). Shadows by ray casting when an occluder is
//! given. On the GPU this comes from the shared irradiance gather (phase 2).
//!
//! ```
//! use translucent::mesh::shapes::Shape;
//! use translucent::solver::dipole::{irradiance::leaf_irradiance, FaceClusterHierarchy};
//! use translucent::scene::{Environment, Scene};
//! let mesh = Shape::Sphere { radius: 10.0 }.triangulate(8);
//! let (tree, _) = FaceClusterHierarchy::build(&mesh)?;
//! let sky = Scene { lights: vec![], environment: Environment::Constant([1.0; 3]) };
//! let e = leaf_irradiance(&tree, &sky, 1.0, None)?;
//! // pi L (1 - F_dr,ext) everywhere; at eta = 1 the F_dr fit leaves F_dr,ext = 0.0016.
//! let want = std::f64::consts::PI * (1.0 - translucent::material::fresnel::diffuse_reflectance(1.0));
//! assert!(e.iter().all(|q| (q[0] - want).abs() < 1e-12), "{:?} vs {want}", e[0]);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use rayon::prelude::*;

use super::hierarchy::FaceClusterHierarchy;
use super::DipoleError;
use crate::material::check_eta;
use crate::mesh::Solid;
use crate::scene::Scene;

/// Transmitted irradiance per leaf (triangle), rgb.
pub fn leaf_irradiance(
    tree: &FaceClusterHierarchy,
    scene: &Scene,
    eta: f64,
    occluder: Option<&dyn Solid>,
) -> Result<Vec<[f64; 3]>, DipoleError> {
    scene.validate()?;
    check_eta(eta)?;
    let t = tree.leaf_count();
    // Shadow rays start this far off the surface: above f64 round-off, far below any triangle.
    let scale = tree.geometry[tree.root() as usize].radius.max(1e-9);
    let offset = 1e-7 * scale;
    Ok(tree.geometry[..t]
        .par_iter()
        .map(|g| {
            if g.area > 0.0 {
                scene.irradiance_at(g.centroid, g.normal, eta, occluder, offset)
            } else {
                [0.0; 3]
            }
        })
        .collect())
}
