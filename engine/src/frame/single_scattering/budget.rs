//! The single-scattering pass's error budget (DESIGN 2.8, "skip below the error budget"): which
//! lights the march takes and when the eye's view makes the march unnecessary.

use glam::DVec3;

use crate::scene::{Environment, Light, Scene};

/// The error budget's rule (DESIGN 2.8, "skip below the error budget"): when every light's
/// direction from the object's centre is within acos(FRONT_LIT_COSINE) of the eye's, the
/// difference to the flat closed form lives only in a thin terminator band the eye sees at a
/// grazing angle, and the march is skipped ([`SkipReason::FrontLit`]). Measured in
/// benches/RESULTS.md ("Single scattering: far-face stop").
pub const FRONT_LIT_COSINE: f64 = 0.5;

/// A light whose largest irradiance anywhere on the object is at most this fraction of the
/// brightest light's or the environment's contributes nothing the frame can show: the march
/// leaves it out, and a frame whose lights are all below it (or black, as `--env-constant`'s
/// placeholder `dir:0,-1,0:0,0,0`) skips the march ([`SkipReason::DarkLights`]). Why 1e-3:
/// single scattering is at most the light's whole share of the radiance, and 1e-3 of the
/// brightest term is a quarter of an 8-bit display step and a tenth of the references' noise
/// (1.1-3.1%, tests/reference/pt/README.md).
pub const DARK_LIGHT_FRACTION: f64 = 1e-3;

/// The largest irradiance `light` can put on a surface facing it within the bounding sphere
/// `(centre, radius)`: its irradiance (directional) or intensity / (distance - radius)^2 (point,
/// spot: the falloff is at most 1); infinite for a non-black light inside the sphere.
pub fn peak_irradiance(light: &Light, bounds: (DVec3, f64)) -> f64 {
    let brightest = |c: [f64; 3]| c.into_iter().fold(0.0, f64::max);
    match *light {
        Light::Directional { irradiance, .. } => brightest(irradiance),
        Light::Point {
            position,
            intensity,
        }
        | Light::Spot {
            position,
            intensity,
            ..
        } => {
            let peak = brightest(intensity);
            let gap = position.distance(bounds.0) - bounds.1;
            if peak == 0.0 {
                0.0
            } else if gap > 0.0 {
                peak / (gap * gap)
            } else {
                f64::INFINITY
            }
        }
    }
}

/// The largest irradiance the environment puts on any surface direction (over the 26
/// directions of a cube's faces, edges and corners for an SH environment: its irradiance is a
/// smooth quadratic in the normal, so the bound is within a few percent).
pub fn peak_environment_irradiance(environment: &Environment) -> f64 {
    let mut peak: f64 = 0.0;
    for x in -1..=1 {
        for y in -1..=1 {
            for z in -1..=1 {
                let n = DVec3::new(f64::from(x), f64::from(y), f64::from(z));
                if n != DVec3::ZERO {
                    let e = environment.irradiance(n.normalize());
                    peak = e.into_iter().fold(peak, f64::max);
                }
            }
        }
    }
    peak
}

/// Which of `scene`'s lights the march takes (`true`): those above [`DARK_LIGHT_FRACTION`] of
/// the brightest light's or the environment's peak irradiance on the bounding sphere `bounds`.
pub fn marched_lights(scene: &Scene, bounds: (DVec3, f64)) -> Vec<bool> {
    let peaks: Vec<f64> = scene
        .lights
        .iter()
        .map(|l| peak_irradiance(l, bounds))
        .collect();
    let brightest = peaks
        .iter()
        .copied()
        .fold(peak_environment_irradiance(&scene.environment), f64::max);
    peaks
        .iter()
        // A light inside the bounding sphere has no finite bound: it darkens none of the others.
        .map(|&p| p > 0.0 && (brightest.is_infinite() || p > DARK_LIGHT_FRACTION * brightest))
        .collect()
}
