//! Light transport beyond the boundary-flux model (DESIGN sections 2.5-2.8), in f64: the exit query
//! from the Fresnel moments (2.6), the collimated source moved into the Robin condition (2.7) and
//! the quantities single scattering (2.8) needs. These are the local, one-dimensional pieces; the
//! solver ([`super::cpu`]) applies them per surface node and per display vertex.
//!
//! Conventions: `z` is the depth into the medium along the inward normal, `dphi` the derivative
//! d phi / d z_in, D = kappa = 1 / (3 sigma_t'), s = sqrt(sigma_a / D), C1 and C2 the Fresnel
//! moments seen from inside ([`fresnel::moment`]).
//!
//! A collimated beam of surface irradiance `irr` (E mu_i, power per unit surface area arriving) is
//! transmitted with T_i, refracted to cosine mu_t and first scattered with density
//! Q0 exp(-beta z), Q0 = gain sigma_s' irr T_i / mu_t, beta = sigma_t' / mu_t (gain 1: the first
//! collision, DESIGN 2.7; the second-collision source: gain about r < 1 and a slower decay fitted
//! to both moments of the true density, see [`second_collision_fit`]). Its particular solution
//! K exp(-beta z),
//! K = Q0 / (sigma_a - D beta^2), leaves the remainder phi_h = phi - K exp(-beta z) with no volume
//! source and the Robin condition phi_h - 2 A D dphi_h = rhs - K (1 + 2 A D beta).
//!
//! ```
//! use translucent::solver::transport::{Boundary, ExitQuery, Optics, Refraction, beam_particular};
//! let b = Boundary::new(1.5, ExitQuery::Moments);
//! assert!((b.a - (1.0 + 3.0 * b.c2) / (1.0 - 2.0 * b.c1)).abs() < 1e-12);
//! // A lit flat half-space of albedo 0.999, light at 30 degrees: the exitance of DESIGN 2.6.
//! let o = Optics { sigma_s: 0.999, sigma_a: 0.001, diffusion: Default::default() };
//! let r = Refraction::new(1.5, 30f64.to_radians().cos());
//! let (k, beta) = beam_particular(o, r, 1.0, 1.0);
//! let m = b.half_space_exitance(o, 0.0, k, -beta * k, -(k + b.h(o) * beta * k));
//! assert!(m > 0.5 && m < 1.0);
//! ```

use std::f64::consts::PI;

use glam::DVec3;

use crate::material::{fresnel, Coefficients, DiffusionCoefficient};

mod profile;
pub use profile::{
    curved_profile_from_sample, lateral_clamp, lateral_lambda, lateral_profile_from_sample,
    profile_from_sample, sample_on_lateral_profile, sample_on_profile, LATERAL_FLOOR,
    LATERAL_LIMIT, LATERAL_LIT_CUT, PROFILE_CURVATURE_LIMIT, SAMPLE_CORRECTION_LIMIT,
};

/// How exitance is read from phi at the surface.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExitQuery {
    /// DESIGN section 2's original model: A = (1 + F_dr) / (1 - F_dr) with the F_dr polynomial,
    /// J+ = (1 + 1/A) phi / 4 - q / (1 + F_dr), L_o = F_t J+ / (pi eta^2).
    #[default]
    Classic,
    /// DESIGN 2.6: A = (1 + 3 C2) / (1 - 2 C1), M = (1 - 2 C1) phi / 4 + (1 - 3 C2) D dphi / 2,
    /// L_o = M (1 - F_r(eta, theta_o)) / (pi (1 - 2 C1(1/eta))).
    Moments,
}

impl std::str::FromStr for ExitQuery {
    type Err = super::SolverError;
    /// `flux` (alias `classic`): the boundary-flux query of DESIGN section 2; `moments`: DESIGN 2.6.
    fn from_str(s: &str) -> Result<Self, super::SolverError> {
        match s {
            "flux" | "classic" => Ok(Self::Classic),
            "moments" => Ok(Self::Moments),
            _ => Err(super::SolverError::BadParameter {
                name: "exit query",
                problem: format!("'{s}' (expected flux or moments)"),
            }),
        }
    }
}

/// Where the lights' transmitted light enters the diffusion equation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Source {
    /// q on the boundary as if already diffuse (DESIGN section 2).
    #[default]
    BoundaryFlux,
    /// DESIGN 2.7: the first-collision density of the refracted beam, as a particular solution
    /// moved into the Robin condition. Carries the once-scattered light in diffusion form.
    Collimated,
    /// DESIGN 2.8's second option: the same with the second-collision density (the part of the
    /// once-scattered light that collides again; [`second_collision_fit`]), single scattering
    /// added whole.
    SecondCollision,
}

/// Single scattering (DESIGN 2.8), added per display vertex for a given eye.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SingleScattering {
    #[default]
    Off,
    /// The march minus the flat-surface closed form (zero on flat lit regions): pairs with
    /// [`Source::Collimated`], which already carries the flat once-scattered light.
    Difference,
    /// The march whole: pairs with [`Source::SecondCollision`].
    Full,
}

/// How exitance reaches the display mesh's vertices.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SurfaceReconstruction {
    /// Shepard weights of 4 surface nodes' values (DESIGN section 3 step 9).
    #[default]
    Shepard,
    /// phi at a point a fixed depth inside, interpolated from the finest level's inner nodes
    /// (`QuadGraph::samples`), extended to the surface by the local 1D profile with the vertex's
    /// own source terms (issue 12 item 4).
    DepthSample,
    /// phi at the same interior sample point, extended to the surface by the same 1D profile,
    /// with the sources (q, the collimated exit part) interpolated from the surface nodes with
    /// the shading weights: what the GPU's `vertex_interior` pass computes (same formulas), and
    /// the default there. Reads no surface node's phi, so the one-neighbour differences
    /// phi_s - phi_k that draw the lattice on the surface (DESIGN 2.6) never reach the image.
    Interior,
}

impl std::str::FromStr for SurfaceReconstruction {
    type Err = super::SolverError;
    /// `shepard` (the surface nodes' values through the shading weights) or `interior`.
    fn from_str(s: &str) -> Result<Self, super::SolverError> {
        match s {
            "shepard" => Ok(Self::Shepard),
            "interior" => Ok(Self::Interior),
            "depth-sample" => Ok(Self::DepthSample),
            _ => Err(super::SolverError::BadParameter {
                name: "surface",
                problem: format!("'{s}' (expected interior or shepard)"),
            }),
        }
    }
}

/// The transport terms of the CPU reference, each on or off (issue 12).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transport {
    pub exit: ExitQuery,
    pub source: Source,
    /// A surface node the light reaches only through the object (the far face of a thin wall)
    /// gets the particular solution of the beam that entered on the near face, attenuated along
    /// the path: exact for a slab. Off: only directly lit nodes carry a particular solution.
    pub continuation: bool,
    /// Walls thinner than this many transport mean free paths along the refracted beam fall back
    /// to the boundary flux (0: never, the measured rule). Measured on the slab against Monte
    /// Carlo (benches/thinwall/slab_rule.py, RESULTS "Thin walls: the beam through the wall"):
    /// with `continuation` the beam's transmission is within 2% at every thickness from 0.5 to 8
    /// mean free paths where the flux is 0.84-0.89 above 3 and up to 3.6x below; without
    /// continuation the beam beats the flux above ~3.3 mean free paths only.
    pub thin_wall_mfp: f64,
    pub single_scattering: SingleScattering,
    pub surface: SurfaceReconstruction,
    /// One bounce of exitance between mutually visible surface points: cosine-weighted rays per
    /// finest surface node (0: off). Light that leaves and re-enters (concave objects).
    pub bounce_rays: u32,
    /// With a beam source and the moments query, the environment enters as beams too (a
    /// quadrature of directions); `false`: as a boundary flux (what the GPU gather does).
    pub environment_beams: bool,
    /// With a beam source: each surface node's beam is taken from upstream on the curved surface
    /// ([`upstream_beam`]; the curvature along the light's tangent from a probe one mean free
    /// path upstream). CPU only so far (benches/RESULTS.md, "The back-lit crescent").
    pub upstream_beam: bool,
    /// With `upstream_beam`: the particular solution below a curved surface (its narrowing
    /// [`beam_particular_curved`] and its lateral terms [`lateral_correction`], irradiance factor
    /// mu_up) instead of wave 8's area factor ([`upstream_beam_with`]); `render --upstream-beam
    /// curved` (benches/RESULTS.md, "The front-lit milk sphere's mid latitudes").
    pub curved_particular: bool,
    /// With a beam source and the interior surface: the collimated part P at a display vertex
    /// follows the vertex's own light visibility (a ray from it) instead of its source nodes'
    /// (`cpu::own_visibility_sources`; the GPU's `GpuSolveParams::own_visibility`, the same
    /// formula): shadow edges as sharp as the display mesh, not the lattice (benches/RESULTS.md,
    /// "Shadow edges on the front-lit bunny"). One light and no environment only.
    pub own_visibility: bool,
}

impl Default for Transport {
    /// The original model of DESIGN section 2 (what the GPU frame computes today).
    fn default() -> Self {
        Self {
            exit: ExitQuery::Classic,
            source: Source::BoundaryFlux,
            continuation: true,
            thin_wall_mfp: 0.0,
            single_scattering: SingleScattering::Off,
            surface: SurfaceReconstruction::Shepard,
            bounce_rays: 0,
            environment_beams: true,
            upstream_beam: false,
            curved_particular: false,
            own_visibility: false,
        }
    }
}

impl Transport {
    /// DESIGN 2.6 + 2.7 + 2.8 with the difference to the flat closed form, depth-sampled surface.
    pub fn collimated() -> Self {
        Self {
            exit: ExitQuery::Moments,
            source: Source::Collimated,
            single_scattering: SingleScattering::Difference,
            surface: SurfaceReconstruction::DepthSample,
            ..Self::default()
        }
    }

    /// What the GPU frame computes with `GpuSolveParams::collimated` (render `--beam-source`): the
    /// moments query, the lights' collimated source at the lit nodes only (no continuation
    /// through the body unless set, as `GpuSolveParams::continuation`; no thin-wall fallback),
    /// the environment as a boundary flux, Shepard shading weights, no single scattering.
    pub fn gpu_collimated() -> Self {
        Self {
            exit: ExitQuery::Moments,
            source: Source::Collimated,
            continuation: false,
            environment_beams: false,
            ..Self::default()
        }
    }

    /// DESIGN 2.6 + second-collision source + single scattering whole, depth-sampled surface.
    pub fn second_collision() -> Self {
        Self {
            exit: ExitQuery::Moments,
            source: Source::SecondCollision,
            single_scattering: SingleScattering::Full,
            surface: SurfaceReconstruction::DepthSample,
            ..Self::default()
        }
    }
}

/// One colour channel's coefficients at a point (1/mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Optics {
    /// Reduced scattering sigma_s'.
    pub sigma_s: f64,
    pub sigma_a: f64,
    /// Which D the diffusion uses ([`DiffusionCoefficient`]).
    pub diffusion: DiffusionCoefficient,
}

impl Optics {
    /// Channel `ch` of `c` with the classical D.
    pub fn channel(c: &Coefficients, ch: usize) -> Self {
        Self::channel_with(c, ch, DiffusionCoefficient::Classical)
    }
    /// Channel `ch` of `c` with the D of `diffusion`.
    pub fn channel_with(c: &Coefficients, ch: usize, diffusion: DiffusionCoefficient) -> Self {
        Self {
            sigma_s: c.sigma_s[ch],
            sigma_a: c.sigma_a[ch],
            diffusion,
        }
    }
    pub fn sigma_t(&self) -> f64 {
        self.sigma_s + self.sigma_a
    }
    pub fn albedo(&self) -> f64 {
        self.sigma_s / self.sigma_t()
    }
    /// D = kappa: 1 / (3 sigma_t') (classical) or (2 sigma_a + sigma_s') / (3 sigma_t'^2).
    pub fn d(&self) -> f64 {
        self.diffusion.d(self.sigma_s, self.sigma_a)
    }
    /// s = sqrt(sigma_a / D).
    pub fn s(&self) -> f64 {
        (self.sigma_a / self.d()).sqrt()
    }
}

/// The boundary: constants of the Robin condition and of the exit query.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Boundary {
    pub exit: ExitQuery,
    pub eta: f64,
    /// A of phi - 2 A D dphi = rhs.
    pub a: f64,
    /// rhs = flux_gain q for a diffuse boundary flux q: 4 / (1 - F_dr), or 4 / (1 - 2 C1).
    pub flux_gain: f64,
    /// The F_dr polynomial (the classic query).
    pub f_dr: f64,
    pub c1: f64,
    pub c2: f64,
    /// 1 - 2 C1(1/eta): the exit lobe's normalization, and the fraction of a constant
    /// environment's irradiance that is transmitted.
    pub exit_norm: f64,
}

impl Boundary {
    pub fn new(eta: f64, exit: ExitQuery) -> Self {
        let f_dr = fresnel::diffuse_reflectance(eta);
        let (c1, c2) = (fresnel::moment1(eta), fresnel::moment2(eta));
        let (a, flux_gain) = match exit {
            ExitQuery::Classic => ((1.0 + f_dr) / (1.0 - f_dr), 4.0 / (1.0 - f_dr)),
            ExitQuery::Moments => ((1.0 + 3.0 * c2) / (1.0 - 2.0 * c1), 4.0 / (1.0 - 2.0 * c1)),
        };
        Self {
            exit,
            eta,
            a,
            flux_gain,
            f_dr,
            c1,
            c2,
            exit_norm: 1.0 - 2.0 * fresnel::moment1(1.0 / eta),
        }
    }

    /// The extrapolation length h = 2 A D.
    pub fn h(&self, o: Optics) -> f64 {
        2.0 * self.a * o.d()
    }

    /// Fraction of a diffuse irradiance that is transmitted: 1 - F_dr,ext (classic, from the
    /// polynomial by reciprocity) or 1 - 2 C1(1/eta) (moments, exact).
    pub fn diffuse_transmittance(&self) -> f64 {
        match self.exit {
            ExitQuery::Classic => 1.0 - fresnel::external_diffuse_reflectance(self.eta),
            ExitQuery::Moments => self.exit_norm,
        }
    }

    /// Exitance leaving the object from phi(0) and dphi/dz_in(0) (total fields); `q_flux` is the
    /// diffuse boundary flux the classic query subtracts (zero for collimated sources).
    /// Classic: (1 - F_dr) J+; moments: DESIGN 2.6's M.
    pub fn exitance(&self, d: f64, phi0: f64, dphi0: f64, q_flux: f64) -> f64 {
        match self.exit {
            ExitQuery::Classic => {
                (1.0 - self.f_dr) * ((1.0 + 1.0 / self.a) * phi0 / 4.0 - q_flux / (1.0 + self.f_dr))
            }
            ExitQuery::Moments => {
                0.25 * (1.0 - 2.0 * self.c1) * phi0 + 0.5 * (1.0 - 3.0 * self.c2) * d * dphi0
            }
        }
    }

    /// [`Self::exitance`] as M = f_phi phi0 + f_d D dphi0 - f_q q_flux: (f_phi, f_d, f_q), the
    /// constants the GPU's `vertex_interior` pass takes.
    pub fn exitance_factors(&self) -> (f64, f64, f64) {
        match self.exit {
            ExitQuery::Classic => (
                (1.0 - self.f_dr) * (1.0 + 1.0 / self.a) / 4.0,
                0.0,
                (1.0 - self.f_dr) / (1.0 + self.f_dr),
            ),
            ExitQuery::Moments => (
                0.25 * (1.0 - 2.0 * self.c1),
                0.5 * (1.0 - 3.0 * self.c2),
                0.0,
            ),
        }
    }

    /// The value X the mesh pass takes per vertex, whose shading F_t(eta, theta_o) X / (pi eta^2)
    /// is the radiance of exitance `m`: J+ = M / (1 - F_dr) (classic) or M eta^2 / (1 - 2 C1(1/eta))
    /// (moments: the lobe (1 - F_r) / (pi (1 - 2 C1(1/eta))) of DESIGN 2.6).
    pub fn shading_input(&self, m: f64) -> f64 {
        match self.exit {
            ExitQuery::Classic => m / (1.0 - self.f_dr),
            ExitQuery::Moments => m * self.eta * self.eta / self.exit_norm,
        }
    }

    /// For a boundary-flux source (rhs = `flux_gain` q, no particular solution) the shading input
    /// per surface node is linear in the node's phi and q: X = f_phi phi - f_q q. The inward
    /// derivative comes from the node's Robin row, dphi/dz_in = (phi - rhs) / (2 A D), so D
    /// cancels: M = (1 - 2 C1) phi / (2 (1 + 3 C2)) - (1 - 3 C2) q / (1 + 3 C2) (moments), and
    /// J+ = (1 + 1/A) phi / 4 - q / (1 + F_dr) (classic). What the GPU's exitance pass computes
    /// (`j_plus.glsl`), the same numbers as [`Self::exitance`] with that derivative.
    pub fn flux_shading_factors(&self) -> (f64, f64) {
        match self.exit {
            ExitQuery::Classic => ((1.0 + 1.0 / self.a) / 4.0, 1.0 / (1.0 + self.f_dr)),
            ExitQuery::Moments => {
                let x = self.shading_input(1.0);
                (
                    x * (1.0 - 2.0 * self.c1) / (2.0 * (1.0 + 3.0 * self.c2)),
                    x * (1.0 - 3.0 * self.c2) / (1.0 + 3.0 * self.c2),
                )
            }
        }
    }

    /// Exitance M of a surface node with a boundary-flux source (see [`Self::flux_shading_factors`]).
    pub fn flux_exitance(&self, phi: f64, q: f64) -> f64 {
        let (f_phi, f_q) = self.flux_shading_factors();
        (f_phi * phi - f_q * q) / self.shading_input(1.0)
    }

    /// The diffusion's tangential flux toward the view, per unit D (render `--tangential-flux`):
    /// in P1 the radiance inside is (phi + 3 J . w) / (4 pi); the exit lobes draw the normal
    /// flux, this is the tangential part J_t = -D grad_t phi. Relative to the Lambertian radiance
    /// of the shading input X (F_t X / (pi eta^2)) it adds -f D grad_t X . w_t with
    /// f = 3 phi / (4 X eta): phi / X from the Robin row without a source (D dphi/dz_in =
    /// phi / (2 A), so M = phi ((1 - 2 C1) + (1 - 3 C2) / A) / 4; classic: (1 - F_dr) J+ with
    /// J+ = (1 + 1/A) phi / 4), grad_t ln phi = grad_t ln X, and 1/eta the refracted w_t. At
    /// eta 1: f = 3/2 (phi = 2 M).
    pub fn tangential_flux_factor(&self) -> f64 {
        let m_per_phi = match self.exit {
            ExitQuery::Classic => (1.0 - self.f_dr) * (1.0 + 1.0 / self.a) / 4.0,
            ExitQuery::Moments => ((1.0 - 2.0 * self.c1) + (1.0 - 3.0 * self.c2) / self.a) / 4.0,
        };
        let x_per_phi = self.shading_input(m_per_phi);
        3.0 / (4.0 * x_per_phi * self.eta)
    }

    /// Radiance leaving toward `cos_o` (outside) for exitance `m`.
    pub fn radiance(&self, m: f64, cos_o: f64) -> f64 {
        fresnel::transmittance(self.eta, cos_o) * self.shading_input(m) / (PI * self.eta * self.eta)
    }

    /// Exitance of a homogeneous half-space whose remainder phi_h = C exp(-s z) meets
    /// phi_h - h dphi_h = `rhs` (the full Robin right-hand side, particular part included), with
    /// the particular solution's surface value `phi_p` and derivative `dphi_p` added back.
    pub fn half_space_exitance(
        &self,
        o: Optics,
        q_flux: f64,
        phi_p: f64,
        dphi_p: f64,
        rhs: f64,
    ) -> f64 {
        let s = o.s();
        let phi_h = rhs / (1.0 + self.h(o) * s);
        self.exitance(o.d(), phi_h + phi_p, -s * phi_h + dphi_p, q_flux)
    }
}

/// Refraction of a beam arriving at cosine `mu_i` (outside): transmittance and inside cosine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Refraction {
    pub mu_i: f64,
    pub t_i: f64,
    pub mu_t: f64,
}

impl Refraction {
    pub fn new(eta: f64, mu_i: f64) -> Self {
        let mu_i = mu_i.clamp(0.0, 1.0);
        Self {
            mu_i,
            t_i: fresnel::transmittance(eta, mu_i),
            mu_t: refracted_cosine(eta, mu_i),
        }
    }
}

/// Cosine to the normal inside of a ray arriving at `cos_outside`: sqrt(1 - (1 - mu^2) / eta^2).
pub fn refracted_cosine(eta: f64, cos_outside: f64) -> f64 {
    (1.0 - (1.0 - cos_outside * cos_outside) / (eta * eta))
        .max(0.0)
        .sqrt()
}

/// The smallest cosine inside a refracted beam keeps: a grazing beam at eta = 1 has mu_t -> 0,
/// beta -> infinity; K stays finite (it goes to 0), this keeps the arithmetic finite.
const MIN_MU_T: f64 = 1e-6;

/// Relative distance kept from the resonance sigma_a = D beta^2 of the particular solution (where
/// K is infinite and phi_h cancels it): the sum phi_h + K exp(-beta z) is continuous there, so
/// shifting beta by this much changes it by as little, while f64 keeps 12 of its 16 digits.
const RESONANCE_GUARD: f64 = 1e-4;

/// K and beta of the particular solution K exp(-beta z) of D phi'' - sigma_a phi = -Q0 exp(-beta z)
/// for a beam of surface irradiance `irr` (E mu_i) refracted as `r`, Q0 = gain sigma_s' irr T_i /
/// mu_t (DESIGN 2.7).
pub fn beam_particular(o: Optics, r: Refraction, irr: f64, gain: f64) -> (f64, f64) {
    beam_particular_curved(o, r, irr, gain, 0.0)
}

/// [`beam_particular`] below a curved surface: `curvature` = H / sigma_t' (the surface's mean
/// curvature H in transport mean free paths, convex > 0, [`UpstreamBeam::curvature`]). Under a
/// surface of mean curvature H the depth z = distance to the surface has Laplacian -2 H (to
/// first order in H z), so D (K e^(-beta z))'' - sigma_a K e^(-beta z) gains D 2 H beta K
/// e^(-beta z), and K e^(-beta z) is the local solution for the source Q0 e^(-beta z) with
/// K = Q0 / (sigma_a - D beta^2 - 2 D H beta) = Q0 / (sigma_a - D beta^2 (1 + 2 (H / sigma_t')
/// mu)), mu = sigma_t' / beta (the fitted cosine of a second-collision source: the deeper the
/// profile, the more of it the convex volume narrows). The planar K (H = 0) put a source
/// (1 + 2 H / beta) times the intended one under a convex surface: 1.15 x the exitance at a
/// skim-milk sphere's lit pole (benches/RESULTS.md, "The front-lit milk sphere's mid
/// latitudes"). |curvature| <= [`UPSTREAM_SHIFT_LIMIT`] keeps the factor within 1 +- 0.4, on
/// the resonance's side of [`beam_share`]'s planar share (which is therefore left planar).
pub fn beam_particular_curved(
    o: Optics,
    r: Refraction,
    irr: f64,
    gain: f64,
    curvature: f64,
) -> (f64, f64) {
    let mu_t = r.mu_t.max(MIN_MU_T);
    let q0 = gain * o.sigma_s * irr * r.t_i / mu_t;
    let d = o.d();
    let curved = 1.0 + 2.0 * curvature * mu_t;
    let mut beta = o.sigma_t() / mu_t;
    let scale = o.sigma_a + d * beta * beta * curved;
    if (o.sigma_a - d * beta * beta * curved).abs() < RESONANCE_GUARD * scale {
        beta *= 1.0 + 2.0 * RESONANCE_GUARD;
    }
    (q0 / (o.sigma_a - d * beta * beta * curved), beta)
}

/// Below this relative distance from the resonance, |sigma_a - D beta^2| / (sigma_a + D beta^2),
/// none of a beam enters as the particular solution; above [`RESONANCE_BEAM_ABOVE`], all of it;
/// between, a smoothstep share (the rest as the boundary flux). Near the resonance K is large
/// and the solve must cancel it with phi_h to a few digits, which a lattice of cells near a mean
/// free path does not: a strongly absorbing channel (skin1 blue, sigma_a mu_t^2 near sigma_t'/3)
/// went 3x too bright with blotches on the split sphere (benches/RESULTS.md, "Model terms on
/// the GPU (wave 5)"). Weakly absorbing media (marble, milk: near 1) are untouched.
pub const RESONANCE_FLUX_BELOW: f64 = 0.25;
/// See [`RESONANCE_FLUX_BELOW`].
pub const RESONANCE_BEAM_ABOVE: f64 = 0.5;

/// The share of a beam (refracted cosine `mu_t`) that enters as the particular solution; the rest
/// enters as the boundary flux ([`RESONANCE_FLUX_BELOW`]). The GPU gather computes the same.
pub fn beam_share(o: Optics, mu_t: f64) -> f64 {
    let mu_t = mu_t.max(MIN_MU_T);
    // sigma_a mu_t^2 against D sigma_t'^2 (sigma_t' / 3 with the classical D).
    let a = o.sigma_a * mu_t * mu_t;
    let b = o.d() * o.sigma_t() * o.sigma_t();
    let x = (a - b).abs() / (a + b);
    let t = ((x - RESONANCE_FLUX_BELOW) / (RESONANCE_BEAM_ABOVE - RESONANCE_FLUX_BELOW))
        .clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The second-collision source relative to the first-collision one, r = I2 / I1 with
/// I = int Q(z) exp(-s z) dz (the only moment of a source the exitance of a half-space depends
/// on). Q2 = sigma_s' times the uncollided fluence of once-scattered light, with one Fresnel
/// reflection (seen from inside) of that light at the boundary. In units of the transport mean
/// free path (s~ = s / sigma_t', b = 1 / mu_t):
/// I2 / I1 = albedo (b + s~) J, J = (1/2) int_0^1 [1 / ((s~ + b)(1 + b mu)) + 1 / ((s~ + b)(1 + s~ mu)) +
/// R(mu) mu / ((1 + s~ mu)(1 + b mu))] dmu.
/// A source Q0 r exp(-beta z) then has the second-collision source's half-space exitance exactly.
pub fn second_collision_ratio(o: Optics, mu_t: f64, eta: f64) -> f64 {
    let b = 1.0 / mu_t.max(MIN_MU_T);
    let s = o.s() / o.sigma_t();
    const N: usize = 64;
    let mut j = 0.0;
    for i in 0..N {
        let mu = (i as f64 + 0.5) / N as f64;
        let r = fresnel::reflectance(1.0 / eta, mu);
        j += (1.0 / ((s + b) * (1.0 + b * mu))
            + 1.0 / ((s + b) * (1.0 + s * mu))
            + r * mu / ((1.0 + s * mu) * (1.0 + b * mu)))
            / N as f64;
    }
    o.albedo() * (b + s) * 0.5 * j
}

/// The deep-moment ratio of the second- to the first-collision source,
/// r_T = int (z + z_b) Q2 dz / int (z + z_b) Q1 dz: the light a diffusion solve carries far from
/// the lit face (across an object) depends on this moment of its source, where the half-space
/// reflectance depends on [`second_collision_ratio`]'s. In mfp units (b = 1 / mu_t, z_b~ = z_b
/// sigma_t'), closed form in depth with the same quadrature over mu, no absorption in the
/// geometry (the s -> 0 limit where the deep field matters) and one Fresnel reflection:
/// r_T (1/b + z_b~) = albedo (1/2) int_0^1 [2 (1/b + z_b~) - (z_b~ - mu) c + R(mu) (z_b~ + mu) c] dmu,
/// c = b mu / (b mu + 1) (the once-scattered light sent up that escapes, or is reflected back).
/// At eta 1, albedo 1: 0.997 at mu_t 1, 0.95 at mu_t 0.1 (team/backlit/moments.py: 0.999, 0.949).
pub fn second_collision_deep_ratio(o: Optics, mu_t: f64, eta: f64, z_b_mfp: f64) -> f64 {
    let b = 1.0 / mu_t.max(MIN_MU_T);
    let zb = z_b_mfp;
    const N: usize = 64;
    let mut j = 0.0;
    for i in 0..N {
        let mu = (i as f64 + 0.5) / N as f64;
        let r = fresnel::reflectance(1.0 / eta, mu);
        let c = b * mu / (b * mu + 1.0);
        j += (2.0 * (1.0 / b + zb) - (zb - mu) * c + r * (zb + mu) * c) / N as f64;
    }
    o.albedo() * 0.5 * j / (1.0 / b + zb)
}

/// The second-collision source as a particular solution fitted to both moments of the true
/// second-collision density (team/backlit/FINDINGS.md): its decay beta' from the deep moment,
/// 1/beta' = (r_T / r)(1/beta + z_b) - z_b ([`second_collision_deep_ratio`]), z_b = `h` = 2 A D,
/// and its gain from the half-space reflectance's moment int Q exp(-s z) dz, kept at r times the
/// first collision's ([`second_collision_ratio`]) exactly. As the beam's arguments of
/// [`beam_particular`]: the effective refracted cosine mu_e = sigma_t' / beta' and the gain
/// relative to Q0 = sigma_s' irr T_i / mu_e, r (1 + s~ mu_e) / (1 + s~ mu_t) (s~ = s / sigma_t').
/// The GPU gather computes the same.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SecondCollisionFit {
    /// r = I2 / I1: the share of the power (and of a flux fallback) the source keeps.
    pub ratio: f64,
    /// The gain to pass to [`beam_particular`] with `mu_e`.
    pub gain: f64,
    /// The effective refracted cosine of the particular solution's decay.
    pub mu_e: f64,
}

/// The deep-moment weight z + z_b is the weak-absorption (s -> 0) limit of the far field
/// sinh(s (z + z_b)) / s: the fit applies fully up to this s / sigma_t' (marble 0.05, skim milk
/// up to 0.149) and fades (smoothstep) to none at [`DEEP_FIT_NONE_ABOVE`]; absorbing channels
/// (skin1 red 0.35, blue 0.98, ketchup) carry little light across an object and keep the plain
/// scaling (with the fit skin1 red front-lit went from 1.09 to 1.13 x the reference; blue
/// went into its particular solution's resonance).
pub const DEEP_FIT_FULL_BELOW: f64 = 0.15;
/// See [`DEEP_FIT_FULL_BELOW`].
pub const DEEP_FIT_NONE_ABOVE: f64 = 0.3;

/// See [`SecondCollisionFit`].
pub fn second_collision_fit(o: Optics, mu_t: f64, eta: f64, h: f64) -> SecondCollisionFit {
    let mu_t = mu_t.max(MIN_MU_T);
    let ratio = second_collision_ratio(o, mu_t, eta);
    let zb = h * o.sigma_t();
    let r_t = second_collision_deep_ratio(o, mu_t, eta, zb);
    let s = o.s() / o.sigma_t();
    let t =
        ((DEEP_FIT_NONE_ABOVE - s) / (DEEP_FIT_NONE_ABOVE - DEEP_FIT_FULL_BELOW)).clamp(0.0, 1.0);
    let weight = t * t * (3.0 - 2.0 * t);
    let mu_e = if ratio > 0.0 {
        mu_t + weight * ((r_t / ratio) * (mu_t + zb) - zb - mu_t).max(0.0)
    } else {
        mu_t
    };
    SecondCollisionFit {
        ratio,
        gain: ratio * (1.0 + s * mu_e) / (1.0 + s * mu_t),
        mu_e,
    }
}

/// Single-scattered radiance of a flat homogeneous half-space (DESIGN 2.8's closed form) per unit
/// surface irradiance `irr`, *without* the exit factor T_o / eta^2:
/// albedo p T_i / (mu_t + mu_o') with p = 1 / (4 pi), mu_o' the view ray's cosine inside.
pub fn flat_single_scattering(albedo: f64, r: Refraction, mu_o_inside: f64, irr: f64) -> f64 {
    albedo / (4.0 * PI) * irr * r.t_i / (r.mu_t + mu_o_inside).max(MIN_MU_T)
}

/// Gauss-Legendre nodes and weights on [0, 1] (8 points): the quadrature of incident cosines for
/// diffuse light (nodes in u = mu_i^2, cosine-weighted, weights summing to 1).
pub const DIFFUSE_NODES: usize = 8;

pub fn diffuse_quadrature() -> [(f64, f64); DIFFUSE_NODES] {
    // Nodes and weights of 8-point Gauss-Legendre on [-1, 1].
    const X: [f64; 4] = [
        0.183_434_642_495_649_8,
        0.525_532_409_916_329,
        0.796_666_477_413_626_7,
        0.960_289_856_497_536_3,
    ];
    const W: [f64; 4] = [
        0.362_683_783_378_362,
        0.313_706_645_877_887_3,
        0.222_381_034_453_374_5,
        0.101_228_536_290_376_3,
    ];
    let mut out = [(0.0, 0.0); DIFFUSE_NODES];
    for k in 0..4 {
        for (slot, sign) in [(3 - k, -1.0), (4 + k, 1.0)] {
            let u = 0.5 * (1.0 + sign * X[k]);
            out[slot] = (u.sqrt(), 0.5 * W[k]);
        }
    }
    out
}

/// An orthonormal frame (t, b) around unit `n`.
pub fn tangent_frame(n: DVec3) -> (DVec3, DVec3) {
    let helper = if n.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
    let t = helper.cross(n).normalize();
    (t, n.cross(t))
}

/// Refracts unit `d` (travelling towards the surface from outside, d . n < 0) through the
/// boundary with outward normal `n` and relative index `eta` (inside / outside).
pub fn refract_inward(d: DVec3, n: DVec3, eta: f64) -> DVec3 {
    let cos_i = (-d.dot(n)).clamp(0.0, 1.0);
    let cos_t = refracted_cosine(eta, cos_i);
    let tangential = (d + n * cos_i) / eta;
    (tangential - n * cos_t).normalize_or(-n)
}

/// The largest |c| = |H| / (eta sigma_t') [`upstream_beam`] uses: the first order in the
/// curvature over a mean free path holds for c << 1 (at c = 0.5 the lit pole would keep nothing);
/// a smaller feature (an edge of a mesh, an ear) is clamped to it.
pub const UPSTREAM_SHIFT_LIMIT: f64 = 0.2;

/// [`UpstreamBeam::curvature`] (the particular solution's narrowing below a convex node) applies in
/// full above this n.l and fades (smoothstep) to none at n.l = 0. The narrowing is the volume below
/// a node lit on every side; at the terminator the light below a node entered upstream over a
/// half-lit neighbourhood, and the ring Monte Carlo's exitance there is better without it on
/// marble (the 10 mm sphere at n.l -0.1..0.1: 0.937-0.966 of the Monte Carlo in full, 0.949-0.987
/// faded over 0..0.3, 0.969-1.002 with wave 8's area factor) while skim milk prefers it (0.99-1.00
/// in full, 1.03-1.04 faded, 1.09-1.10 with the area factor): `benches/milk10/cont2.py R,G,B
/// 0,1,-0.5 0,1,-0.5,0.3` (benches/RESULTS.md, "The front-lit milk sphere's mid latitudes").
pub const NARROWING_FULL_ABOVE: f64 = 0.3;

/// A beam entering a curved surface, as a surface node's source sees it (issue 12, the back-lit
/// crescent: benches/RESULTS.md "The back-lit crescent, term by term"). A beam travels a lateral
/// mean free path sqrt(1 - mu_t^2) / sigma_t' = sin(theta_i) / (eta sigma_t') along the surface
/// before its first collision, so the light that collides below a node entered upstream, where
/// (on a surface of mean curvature H, convex > 0) the cosine to the light is larger by the angle
/// turned, a = H sin(theta_i) / (eta sigma_t'): to first order in c = H / (eta sigma_t'),
/// mu_up = mu + c (1 - mu^2). The default ([`upstream_beam_with`] `curved` false, wave 8): the
/// map's area ratio (1 - c mu)^2 spreads it, irradiance factor mu + c (1 - 3 mu^2), which keeps
/// a sphere's lit power to O(c^2). Curved ([`upstream_beam`], `Transport::curved_particular`):
/// at eta 1 the first-collision density per volume below the node is E sigma_s' exp(-sigma_t'
/// chord), whatever the surface's slope, so the irradiance factor (what replaces mu_i in E mu_i;
/// T_i and mu_t at mu_up) is mu_up and the narrowing of the convex volume below the node is
/// the particular solution's own curvature term ([`beam_particular_curved`] with
/// [`UpstreamBeam::curvature`]), scaling with the (fitted) depth of the profile rather than with
/// mu: the area factor over-lights a front-lit skim-milk sphere's mid latitudes by 10-20% in red,
/// the curved one takes 3-5% of the light reaching the far side (benches/RESULTS.md, "The
/// front-lit milk sphere's mid latitudes"). Either lights the unlit side
/// within about c of the terminator. The planar model (c = 0) puts every first
/// collision below its entry node: on the 10 mm marble sphere its exitance is 0.70 of the
/// transport's at the terminator.
///
/// On a surface that is not umbilic the two curvatures differ (issue 12, the back-lit torus:
/// benches/RESULTS.md "The back-lit torus, region by region"): the beam turns by the normal
/// curvature k_t along its tangent direction t (the projection of l on the tangent plane), so
/// mu_up = mu + c_t (1 - mu^2) with c_t = k_t / (eta sigma_t'), while the volume's narrowing is
/// the mean curvature's (the Laplacian of the depth is -2 H on any surface).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UpstreamBeam {
    /// The cosine to the light where the beam entered: the incidence of its Fresnel
    /// transmittance and refraction.
    pub mu_up: f64,
    /// Replaces mu_i in the surface irradiance E mu_i (0 where the node receives nothing).
    pub irradiance: f64,
    /// The mean curvature in transport mean free paths, H / sigma_t' (clamped to
    /// +-[`UPSTREAM_SHIFT_LIMIT`]): the particular solution's ([`beam_particular_curved`]).
    pub curvature: f64,
}

/// See [`UpstreamBeam`]; `mu` = n . l at the node (may be negative near the terminator),
/// `curvature` the node's [`SurfaceCurvature`] (1/mm), `t` the beam's unit tangent direction
/// (l - n mu normalized; any tangent where l is along n), `sigma_t` = sigma_t' (1/mm) of the
/// node's channel.
pub fn upstream_beam(
    mu: f64,
    curvature: SurfaceCurvature,
    t: DVec3,
    sigma_t: f64,
    eta: f64,
) -> UpstreamBeam {
    upstream_beam_with(mu, curvature, t, sigma_t, eta, true)
}

/// [`upstream_beam`] with `curved` false: wave 8's area factor, irradiance factor
/// mu + c_t (1 - mu^2) - 2 c mu^2 (c = H / (eta sigma_t')) and a planar particular solution
/// (curvature 0): `Transport::curved_particular` off, render's default.
pub fn upstream_beam_with(
    mu: f64,
    curvature: SurfaceCurvature,
    t: DVec3,
    sigma_t: f64,
    eta: f64,
    curved: bool,
) -> UpstreamBeam {
    let shift = |k: f64| {
        if k.is_finite() && sigma_t > 0.0 && eta > 0.0 {
            (k / (eta * sigma_t)).clamp(-UPSTREAM_SHIFT_LIMIT, UPSTREAM_SHIFT_LIMIT)
        } else {
            0.0
        }
    };
    let c_t = shift(curvature.along(t));
    let mu = mu.clamp(-1.0, 1.0);
    let mu_up = (mu + c_t * (1.0 - mu * mu)).min(1.0);
    if !curved {
        let c = shift(curvature.mean);
        let irradiance = if mu_up > 0.0 {
            (mu + c_t * (1.0 - mu * mu) - 2.0 * c * mu * mu).max(0.0)
        } else {
            0.0
        };
        return UpstreamBeam {
            mu_up,
            irradiance,
            curvature: 0.0,
        };
    }
    // Curved in full on an umbilic node, wave 8's area factor where the principal curvatures
    // differ most ([`SurfaceCurvature::umbilic_share`]), blended between.
    let share = curvature.umbilic_share();
    let irradiance = if mu_up > 0.0 {
        let c = shift(curvature.mean);
        let area = (mu + c_t * (1.0 - mu * mu) - 2.0 * c * mu * mu).max(0.0);
        share * mu_up + (1.0 - share) * area
    } else {
        0.0
    };
    // The particular solution's curvature is geometric (eta does not enter the Laplacian), in
    // full from n.l = NARROWING_FULL_ABOVE, faded (smoothstep) to none at the terminator.
    let fade = (mu / NARROWING_FULL_ABOVE).clamp(0.0, 1.0);
    let curvature = if mu_up > 0.0 {
        share * shift(curvature.mean * eta) * fade * fade * (3.0 - 2.0 * fade)
    } else {
        0.0
    };
    UpstreamBeam {
        mu_up,
        irradiance,
        curvature,
    }
}

/// The step in n.l of [`lateral_correction`]'s finite differences (f32 keeps the second
/// difference of K to about 1e-7 / LATERAL_STEP^2 = 3e-4 of K on the GPU).
pub const LATERAL_STEP: f64 = 0.02;

/// [`lateral_correction`] applies in full above this n.l and fades (smoothstep from n.l = 0) below:
/// the expansion in lateral derivatives needs K to vary little over a profile's depth along the
/// surface, which fails within a few c of the lit edge (mu_up -> 0, where beta = sigma_t' / mu_e
/// and K turn within a mean free path). Without the fade the continuous sphere's exitance at n.l
/// -0.2..0.1 drops to 0.86-0.95 of the Monte Carlo's (0.94-1.01 with it;
/// `benches/milk10/cont2.py mR,mG,mB 0,1,1` against `0,1,-0.5`).
pub const LATERAL_FULL_ABOVE: f64 = 0.5;

/// [`lateral_correction`]'s guard: in full where the unclamped curvature in transport mean free
/// paths, sqrt(g) / sigma_t', is below this, none from [`UPSTREAM_SHIFT_LIMIT`] (smoothstep
/// between). The second order in c is the first to fail where c is not small: the 20 mm ketchup
/// sphere's red (sigma_t' 0.24/mm, c = 0.41, clamped to 0.2) went 16 -> 26% relative RMS with the
/// term, while skim milk's red (c = 0.14) needs it in full.
pub const LATERAL_GUARD_FROM: f64 = 0.15;

/// The particular solution's lateral terms (second order in the curvature): K(mu) e^(-beta(mu) z)
/// varies along the surface with the node's cosine mu = n . l, so its surface Laplacian
/// f'' |grad mu|^2 + f' Lap(mu) is a source the planar particular solution leaves out. With the
/// shape operator S (principal curvatures k1, k2), grad mu = S l_t (l_t = l - n mu) and
/// Lap(mu) = Lap(n) . l = -(k1^2 + k2^2) mu (H's gradient left out), so the surface Laplacian is
/// g [r (1 - mu^2) f'' - 2 mu f'] with g = (k1^2 + k2^2) / 2 = H^2 + |a|^4
/// ([`SurfaceCurvature::squared`], at most (UPSTREAM_SHIFT_LIMIT sigma_t')^2) and r = g_t / g,
/// g_t = |S t|^2 the squared curvature along the beam's tangent t
/// ([`SurfaceCurvature::squared_along`], `g_along`; r in [0, 2], 1 on a sphere, where this is
/// g L[f] with g = 1 / R^2). Integrated over depth (moments 1/beta, 1/beta^2, 2/beta^3 of
/// e^(-beta z), z e^(-beta z), z^2 e^(-beta z)) and folded into K:
/// dK = D g lat beta / (sigma_a - D beta^2 (1 + 2 c mu_e)), lat = L[K] / beta - (2 w K' beta' +
/// K L[beta]) / beta^2 + 2 K beta'^2 w / beta^3, L[f] = w f'' - 2 mu f', w = r (1 - mu^2). At a skim-milk sphere's lit pole (red, c = 0.14) it is +9% of K, +1.4% for marble
/// red; it lifts the continuous sphere's lit cap from 0.96-0.99 to 1.00-1.01 of the Monte Carlo
/// (benches/RESULTS.md, "The front-lit milk sphere's mid latitudes"). `at(mu)` gives (K, beta)
/// of the node's beam (everything else held) for a node cosine `mu`; derivatives by central
/// differences of [`LATERAL_STEP`] about min(mu, 1 - step) (K is smooth in mu up to the pole);
/// 0 where any of the three is unlit or not finite, faded out where the unclamped curvature
/// reaches the clamp ([`LATERAL_GUARD_FROM`]). `curvature` = H / sigma_t' (clamped, as
/// [`UpstreamBeam::curvature`]), `g` and `g_along` in 1/mm^2. The GPU gather computes the same.
pub fn lateral_correction(
    o: Optics,
    mu: f64,
    curvature: f64,
    (g, g_along): (f64, f64),
    at: impl Fn(f64) -> (f64, f64),
) -> f64 {
    let step = LATERAL_STEP;
    let t = (mu / LATERAL_FULL_ABOVE).clamp(0.0, 1.0);
    let fade = t * t * (3.0 - 2.0 * t);
    let sigma_t = o.sigma_t();
    // NaN fails the test (f64::min would return the clamp for it).
    if fade == 0.0 || g.is_nan() || g <= 0.0 {
        return 0.0;
    }
    // The guard: none where the unclamped curvature sqrt(g) / sigma_t' reaches the clamp.
    let u = ((g.sqrt() / sigma_t - LATERAL_GUARD_FROM)
        / (UPSTREAM_SHIFT_LIMIT - LATERAL_GUARD_FROM))
        .clamp(0.0, 1.0);
    let fade = fade * (1.0 - u * u * (3.0 - 2.0 * u));
    if fade == 0.0 {
        return 0.0;
    }
    let g = g.min((UPSTREAM_SHIFT_LIMIT * sigma_t).powi(2));
    let m = mu.min(1.0 - step);
    let ((k0, b0), (kp, bp), (km, bm)) = (at(m), at(m + step), at(m - step));
    if [k0, kp, km, b0, bp, bm]
        .iter()
        .any(|v| !v.is_finite() || *v == 0.0)
    {
        return 0.0;
    }
    let (dk, d2k) = (
        (kp - km) / (2.0 * step),
        (kp - 2.0 * k0 + km) / (step * step),
    );
    let (db, d2b) = (
        (bp - bm) / (2.0 * step),
        (bp - 2.0 * b0 + bm) / (step * step),
    );
    // |grad mu|^2 / g over (1 - mu^2): the beam's direction's share of the curvature.
    let r = if g_along.is_finite() {
        (g_along / g).clamp(0.0, 2.0)
    } else {
        1.0
    };
    let w = r * (1.0 - m * m);
    let (lk, lb) = (w * d2k - 2.0 * m * dk, w * d2b - 2.0 * m * db);
    let lat = lk / b0 - (2.0 * w * dk * db + k0 * lb) / (b0 * b0)
        + 2.0 * k0 * db * db * w / (b0 * b0 * b0);
    let d = o.d();
    let denom = o.sigma_a - d * b0 * b0 * (1.0 + 2.0 * curvature * sigma_t / b0);
    let dk_total = fade * d * g * lat * b0 / denom;
    if dk_total.is_finite() {
        dk_total
    } else {
        0.0
    }
}

/// [`SurfaceCurvature::umbilic_share`]'s power: 1, 2 and 4 measured on the bunny and the torus
/// (benches/RESULTS.md, "The curved particular solution on non-spherical surfaces").
pub const UMBILIC_SHARE_POWER: i32 = 4;

/// The curvature of the surface at a node (1/mm, convex > 0): the mean curvature H = (k1 + k2)
/// / 2 and the anisotropy a = e1 sqrt((k1 - k2) / 2), e1 the unit direction of the larger
/// principal curvature k1, so that the normal curvature along a unit tangent t is
/// k_t = H + (k1 - k2) / 2 cos(2 angle(t, e1)) = H - |a|^2 + 2 (t . a)^2 (Euler's theorem).
/// The sign of a is irrelevant; a sphere's or a plane's is zero.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SurfaceCurvature {
    pub mean: f64,
    pub anisotropy: DVec3,
}

impl SurfaceCurvature {
    /// An umbilic point's (every direction curves by `mean`).
    pub fn umbilic(mean: f64) -> SurfaceCurvature {
        SurfaceCurvature {
            mean,
            anisotropy: DVec3::ZERO,
        }
    }

    /// (k1^2 + k2^2) / 2 = H^2 + |a|^4: the mean over directions of the squared normal
    /// curvature, the surface Laplacian's scale in [`lateral_correction`] (0 if not finite).
    pub fn squared(&self) -> f64 {
        let g = self.mean * self.mean + self.anisotropy.length_squared().powi(2);
        if g.is_finite() {
            g
        } else {
            0.0
        }
    }

    /// (1 - |k1 - k2| / (|k1| + |k2|))^[`UMBILIC_SHARE_POWER`]: 1 on an umbilic node (a sphere's; or a plane's), 0 where
    /// one principal curvature is zero (a cylinder's) or they are opposite (a saddle's). The
    /// curved particular solution's share ([`upstream_beam`]; its lateral term alike): its
    /// narrowing and lateral term help a sphere lit from the front but cost the bunny and the
    /// torus (benches/RESULTS.md, "The curved particular solution on non-spherical surfaces").
    pub fn umbilic_share(&self) -> f64 {
        let a2 = self.anisotropy.length_squared();
        let sum = (self.mean + a2).abs() + (self.mean - a2).abs();
        let share = 1.0 - 2.0 * a2 / sum;
        if share.is_finite() {
            share.clamp(0.0, 1.0).powi(UMBILIC_SHARE_POWER)
        } else {
            1.0
        }
    }

    /// |S t|^2 = k1^2 (t . e1)^2 + k2^2 (t . e2)^2 = [`Self::squared`] + 2 H (k_t - H): the
    /// squared curvature along the unit tangent `t` (the rate at which the normal turns moving
    /// along t), [`lateral_correction`]'s `g_along` (0 if not finite).
    pub fn squared_along(&self, t: DVec3) -> f64 {
        let g = self.squared() + 2.0 * self.mean * (self.along(t) - self.mean);
        if g.is_finite() {
            g.max(0.0)
        } else {
            0.0
        }
    }

    /// The normal curvature along the unit tangent `t` (see the type's doc).
    pub fn along(&self, t: DVec3) -> f64 {
        let a = self.anisotropy;
        let k = self.mean - a.length_squared() + 2.0 * t.dot(a).powi(2);
        if k.is_finite() {
            k
        } else {
            self.mean
        }
    }
}

#[cfg(test)]
mod tests;
