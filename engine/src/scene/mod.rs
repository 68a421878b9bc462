//! The scene every pass and method reads (DESIGN sections 2 and 8): lights, the environment, the
//! camera and how outgoing radiance is computed. Positions and directions are in millimetres in the
//! normalized object frame, +Y up, right-handed; colours are linear RGB.
//!
//! - [`Light`]: directional, point and spot lights, parsed from the command-line syntax.
//! - [`Environment`]: none, constant, or order-2 spherical harmonics (from an EXR map).
//! - [`Camera`]: a pinhole camera looking from eye to target.
//! - [`ExitLobe`]: the angular shape of the radiance leaving the surface (`--exit-lobe`);
//!   [`own_lobe`]: Chandrasekhar's shape of a node's own light ([`ExitLobe::Chandra`]).
//! - [`Scene`]: what lights the object, and the transmitted irradiance q it gives a surface point.
//!
//! ```
//! use translucent::scene::{Environment, Light, Scene};
//! let scene = Scene {
//!     lights: vec!["dir:0,-1,0:3,3,3".parse()?],
//!     environment: Environment::Constant([0.1; 3]),
//! };
//! scene.validate()?;
//! // q on a surface facing the light, eta 1.3, no occluder:
//! let q = scene.irradiance_at(glam::DVec3::ZERO, glam::DVec3::Y, 1.3, None, 0.0);
//! assert!(q[0] > 2.9);
//! # Ok::<(), translucent::scene::SceneError>(())
//! ```

mod camera;
mod environment;
mod environment_map;
mod exit_lobe;
mod light;
pub mod own_lobe;

use glam::DVec3;
use rayon::prelude::*;

use crate::material::fresnel;
use crate::mesh::Solid;
use crate::quadgraph::graph::GraphLevel;

pub use camera::{Camera, FOVY_RANGE_DEG, MAX_CAMERA_MM};
pub use environment::Environment;
pub use environment_map::equirect_direction;
pub use exit_lobe::{
    diffused_share, inside_cosine, ExitLobe, FITTED_SLOPE_SHARE, OWN_SOURCE_SLOPE_SHARE,
};
pub use light::{Light, MAX_LIGHT_COLOUR};

/// A bad light, environment, camera or mode, naming it and the problem.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{what}: {problem}")]
    Invalid { what: String, problem: String },
    /// An input above a resource limit ([`crate::limits`]), named with how to raise it.
    #[error("{what}: {source}")]
    Limit {
        what: String,
        source: crate::limits::LimitExceeded,
    },
}

/// How outgoing radiance is computed from the surface exitance (DESIGN section 2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RadianceMode {
    /// L_o = F_t(eta, theta_o) J+ / (pi eta^2): radiance crossing into air loses eta^2; integrated
    /// over the hemisphere this returns (1 - F_dr) J+.
    #[default]
    Physical,
    /// The paper's Eq. 4 (its Eq. 7 prints F_r, a typo): L_o = F_t J+ / pi.
    Paper,
}

impl std::str::FromStr for RadianceMode {
    type Err = SceneError;
    /// `physical` or `paper` (the CLI's `--radiance`).
    fn from_str(s: &str) -> Result<Self, SceneError> {
        match s {
            "physical" => Ok(Self::Physical),
            "paper" => Ok(Self::Paper),
            _ => Err(SceneError::Invalid {
                what: "radiance".into(),
                problem: format!("'{s}' (expected physical or paper)"),
            }),
        }
    }
}

/// Everything that lights the object.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Scene {
    pub lights: Vec<Light>,
    pub environment: Environment,
}

impl Scene {
    pub fn validate(&self) -> Result<(), SceneError> {
        self.lights.iter().try_for_each(Light::validate)?;
        self.environment.validate()
    }

    /// Transmitted irradiance q at one surface point with outward unit normal `n`. Lights are shadowed
    /// by `occluder` (a ray from `p + offset n` towards the light) when one is given.
    pub fn irradiance_at(
        &self,
        p: DVec3,
        n: DVec3,
        eta: f64,
        occluder: Option<&dyn Solid>,
        offset: f64,
    ) -> [f64; 3] {
        let t_env = 1.0 - fresnel::external_diffuse_reflectance(eta);
        self.irradiance_at_with(p, n, eta, occluder, offset, t_env)
    }

    /// [`Self::irradiance_at`] with the environment's transmitted fraction `t_env` given (the
    /// moments query of DESIGN 2.6 uses 1 - 2 C1(1/eta) instead of 1 - F_dr,ext).
    pub fn irradiance_at_with(
        &self,
        p: DVec3,
        n: DVec3,
        eta: f64,
        occluder: Option<&dyn Solid>,
        offset: f64,
        t_env: f64,
    ) -> [f64; 3] {
        let mut q = [0.0; 3];
        for light in &self.lights {
            let (e, l, dist) = light.arriving(p);
            let cos = n.dot(l);
            if cos <= 0.0 || e.iter().all(|&v| v == 0.0) {
                continue;
            }
            if let Some(solid) = occluder {
                let origin = p + n * offset;
                if solid.ray_hit(origin, l, dist).is_some() {
                    continue;
                }
            }
            let t = cos * fresnel::transmittance(eta, cos);
            for c in 0..3 {
                q[c] += e[c] * t;
            }
        }
        let env = self.environment.irradiance(n);
        for c in 0..3 {
            q[c] += env[c] * t_env;
        }
        q
    }

    /// q at every surface node of a level (indexed by surface index `s`).
    pub fn surface_irradiance(
        &self,
        level: &GraphLevel,
        eta: f64,
        occluder: Option<&dyn Solid>,
    ) -> Vec<[f64; 3]> {
        let t_env = 1.0 - fresnel::external_diffuse_reflectance(eta);
        self.surface_irradiance_with(level, eta, occluder, t_env)
    }

    /// [`Self::surface_irradiance`] with the environment's transmitted fraction `t_env` given.
    pub fn surface_irradiance_with(
        &self,
        level: &GraphLevel,
        eta: f64,
        occluder: Option<&dyn Solid>,
        t_env: f64,
    ) -> Vec<[f64; 3]> {
        let inner = level.inner_count();
        // Far enough off the surface to miss it under f64 round-off, far below the lattice scale.
        let offset = 1e-4 * level.spacing.max(1e-6);
        (0..level.surface_count())
            .into_par_iter()
            .map(|s| {
                self.irradiance_at_with(
                    level.positions[inner + s],
                    level.surface_normals[s],
                    eta,
                    occluder,
                    offset,
                    t_env,
                )
            })
            .collect()
    }
}
