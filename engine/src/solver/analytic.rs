//! Closed-form solutions of the continuous diffusion problem of DESIGN section 2 (homogeneous
//! material, one channel): the oracles the discrete solvers are measured against.
//!
//! ```
//! use translucent::material::Material;
//! use translucent::solver::analytic::Homogeneous;
//! let marble = Material::preset("marble")?;
//! let red = Homogeneous::channel(&marble, 0);
//! assert!((red.sphere_albedo(10.0) - 0.9552).abs() < 1e-4);
//! let milk = Homogeneous::channel(&Material::preset("skimmilk")?, 0);
//! assert!((milk.slab_transmittance(10.0) - 0.2090).abs() < 1e-4);
//! # Ok::<(), translucent::material::MaterialError>(())
//! ```

use crate::material::{fresnel, Material};

/// One channel of a homogeneous material, with the derived constants of the Robin boundary.
#[derive(Clone, Copy, Debug)]
pub struct Homogeneous {
    /// Diffusion coefficient D = kappa = 1 / (3 sigma_t').
    pub d: f64,
    /// Absorption sigma_a.
    pub sigma_a: f64,
    /// Effective transport coefficient s = sqrt(3 sigma_a sigma_t') = sqrt(sigma_a / D).
    pub s: f64,
    /// Internal diffuse reflectance F_dr.
    pub f_dr: f64,
    /// A = (1 + F_dr) / (1 - F_dr).
    pub a: f64,
}

impl Homogeneous {
    /// Channel `c` of `m`.
    pub fn channel(m: &Material, c: usize) -> Self {
        Self::new(m.sigma_s[c], m.sigma_a[c], m.eta)
    }

    pub fn new(sigma_s: f64, sigma_a: f64, eta: f64) -> Self {
        let sigma_t = sigma_s + sigma_a;
        Self {
            d: 1.0 / (3.0 * sigma_t),
            sigma_a,
            s: (3.0 * sigma_a * sigma_t).sqrt(),
            f_dr: fresnel::diffuse_reflectance(eta),
            a: fresnel::boundary_a(eta),
        }
    }

    /// The extrapolation length h = 2 A D of the boundary condition phi + h dphi/dn = 4q/(1 - F_dr).
    pub fn h(&self) -> f64 {
        2.0 * self.a * self.d
    }

    /// Outgoing partial current J+ = (1 + 1/A) phi / 4 - q / (1 + F_dr) at a boundary point.
    pub fn j_plus(&self, phi: f64, q: f64) -> f64 {
        (1.0 + 1.0 / self.a) * phi / 4.0 - q / (1.0 + self.f_dr)
    }

    /// Sphere of radius `r` under uniform q: phi(r) = alpha sinh(s r)/r; albedo = exitance / q =
    /// (1 - F_dr) J+(R) / q.
    pub fn sphere_albedo(&self, r: f64) -> f64 {
        let q = 1.0;
        let big_q = 4.0 * q / (1.0 - self.f_dr);
        // s coth(sR) - 1/R, with its sigma_a -> 0 limit (s^2 R / 3) where coth would overflow.
        let sr = self.s * r;
        let g = if sr < 1e-4 {
            self.s * self.s * r / 3.0
        } else {
            self.s / sr.tanh() - 1.0 / r
        };
        let phi_r = big_q / (1.0 + self.h() * g);
        (1.0 - self.f_dr) * self.j_plus(phi_r, q) / q
    }

    /// Slab of thickness `d` lit uniformly on one face: transmitted exitance / q on the far face,
    /// T = (4 D s/(1 - F_dr)) / [(1 + h^2 s^2) sinh(s d) + 2 h s cosh(s d)].
    pub fn slab_transmittance(&self, d: f64) -> f64 {
        let (h, s) = (self.h(), self.s);
        if s * d < 1e-8 {
            // sigma_a -> 0 limit: T = (4 D / (1 - F_dr)) / (d + 2 h).
            return 4.0 * self.d / (1.0 - self.f_dr) / (d + 2.0 * h);
        }
        (4.0 * self.d * s / (1.0 - self.f_dr))
            / ((1.0 + h * h * s * s) * (s * d).sinh() + 2.0 * h * s * (s * d).cosh())
    }

    /// Semi-infinite medium under uniform light: albedo = [2/(1 + 2 A D s) - (1 - F_dr)] / (1 + F_dr).
    pub fn semi_infinite_albedo(&self) -> f64 {
        (2.0 / (1.0 + self.h() * self.s) - (1.0 - self.f_dr)) / (1.0 + self.f_dr)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The semi-infinite formula is the large-R limit of the sphere and the large-d limit of the
    /// reflectance of a slab; check it against the sphere (independent derivation) and its own limits.
    #[test]
    fn semi_infinite_albedo_is_the_large_sphere_limit() {
        for name in ["marble", "skin1", "ketchup", "skimmilk"] {
            let m = Material::preset(name).unwrap();
            for c in 0..3 {
                let h = Homogeneous::channel(&m, c);
                let big = h.sphere_albedo(1e6 / h.s.max(1e-9));
                assert!((big - h.semi_infinite_albedo()).abs() < 1e-6, "{name} {c}");
                assert!(h.semi_infinite_albedo() < 1.0);
            }
        }
        // sigma_a = 0: everything that enters leaves.
        let h = Homogeneous::new(1.0, 0.0, 1.3);
        assert!((h.semi_infinite_albedo() - 1.0).abs() < 1e-12);
        assert!((h.sphere_albedo(10.0) - 1.0).abs() < 1e-12);
        // Index-matched, weakly absorbing: albedo -> 1 - O(sqrt(sigma_a / sigma_t)).
        let h = Homogeneous::new(1.0, 1e-6, 1.0);
        assert!(h.semi_infinite_albedo() > 0.99);
    }

    #[test]
    fn design_numbers() {
        let marble = Material::preset("marble").unwrap();
        assert!((Homogeneous::channel(&marble, 0).sphere_albedo(10.0) - 0.9552).abs() < 5e-5);
        let milk = Material::preset("skimmilk").unwrap();
        assert!((Homogeneous::channel(&milk, 0).slab_transmittance(10.0) - 0.2090).abs() < 5e-5);
        // Continuity of the small-s branches.
        let h = Homogeneous::new(1.0, 1e-18, 1.3);
        let h0 = Homogeneous::new(1.0, 0.0, 1.3);
        assert!((h.slab_transmittance(5.0) - h0.slab_transmittance(5.0)).abs() < 1e-6);
    }
}
