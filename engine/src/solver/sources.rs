//! The source terms of one surface point (a surface node, or a display vertex for the exit query):
//! what the lights and the environment bring in, in the form [`Transport`] asks for (DESIGN
//! sections 2, 2.6, 2.7): a diffuse boundary flux q, or per beam the particular solution
//! K exp(-beta z) moved into the Robin condition.
//!
//! Per light and point, [`arrival`] decides by ray casting (exact visibility, as the path tracer
//! has it) whether the light arrives directly (lit), through the object (the point lies behind
//! material the beam entered on the light's side: the far face of a thin wall), or not at all.
//!
//! ```
//! use glam::DVec3;
//! use translucent::material::{Material, MaterialField};
//! use translucent::mesh::shapes::Shape;
//! use translucent::solver::sources::SourceModel;
//! use translucent::solver::transport::{Boundary, ExitQuery, Transport};
//! use translucent::scene::Scene;
//! let marble = MaterialField::Homogeneous(Material::preset("marble")?);
//! let slab = Shape::Box { half_extents: DVec3::new(50.0, 1.0, 50.0) };
//! let scene = Scene { lights: vec!["dir:0,-1,0:1,1,1".parse()?], ..Default::default() };
//! let model = SourceModel::new(&scene, &marble, Some(&slab), Transport::collimated(), 1e-4);
//! let top = model.at(DVec3::new(0.0, 1.0, 0.0), DVec3::Y);
//! let bottom = model.at(DVec3::new(0.0, -1.0, 0.0), -DVec3::Y);
//! assert!(top.phi_p[0] < 0.0 && top.transmitted[0] > 0.9); // lit: a beam's particular solution
//! assert!(bottom.phi_p[0] != 0.0 && bottom.transmitted[0] == 0.0); // behind 2 mm of marble
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

// why: the per-channel loops index several [f64; 3] arrays (sources, coefficients, h) at once.
#![allow(clippy::needless_range_loop)]

use std::f64::consts::PI;

use glam::DVec3;

use super::transport::{
    beam_particular, beam_particular_curved, beam_share, diffuse_quadrature, lateral_correction,
    second_collision_fit, tangent_frame, upstream_beam, upstream_beam_with, Boundary, ExitQuery,
    Optics, Refraction, Source, SurfaceCurvature, Transport, UPSTREAM_SHIFT_LIMIT,
};
use crate::material::{Coefficients, MaterialField};
use crate::mesh::Solid;
use crate::scene::{Environment, Light, Scene};

/// Optical depth beyond which a beam is taken to be extinguished (exp(-30) ~ 1e-13).
const MAX_OPTICAL_DEPTH: f64 = 30.0;

/// Samples of the material along a segment for heterogeneous optical depths (midpoint rule).
const DEPTH_SAMPLES: usize = 8;

/// What one surface point receives, per channel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocalSource {
    /// Right-hand side of the Robin condition of the remainder phi_h (particular part included).
    pub rhs: [f64; 3],
    /// The particular solutions' value at the point and derivative along the inward normal,
    /// added back at the exit query.
    pub phi_p: [f64; 3],
    pub dphi_p: [f64; 3],
    /// The diffuse boundary flux q (what the classic exit query subtracts).
    pub q_flux: [f64; 3],
    /// Power transmitted into the object per unit area (lights reaching the point directly and
    /// the environment): the energy input.
    pub transmitted: [f64; 3],
    /// Power absorbed before it reaches the diffusion remainder, per unit area: the uncollided
    /// beam and the particular solution (sigma_a K / beta).
    pub absorbed: [f64; 3],
}

impl LocalSource {
    /// Adds another source's terms (right-hand sides included: both must use the same h).
    pub fn add(&mut self, other: &LocalSource) {
        for c in 0..3 {
            self.rhs[c] += other.rhs[c];
            self.phi_p[c] += other.phi_p[c];
            self.dphi_p[c] += other.dphi_p[c];
            self.q_flux[c] += other.q_flux[c];
            self.transmitted[c] += other.transmitted[c];
            self.absorbed[c] += other.absorbed[c];
        }
    }
}

/// How a light reaches a point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Arrival {
    /// Directly: irradiance on a surface facing the light and the cosine to the normal.
    Lit {
        irradiance: [f64; 3],
        mu_i: f64,
    },
    /// Through the object: the beam entered at `entry` (outward normal `normal`, cosine `mu_i`)
    /// and travelled `distance` inside (straight, towards the light) to the point.
    Behind {
        irradiance: [f64; 3],
        entry: DVec3,
        normal: DVec3,
        mu_i: f64,
        distance: f64,
    },
    Dark,
}

/// Whether and how `light` reaches the surface point `x` (outward normal `n`); `offset` lifts ray
/// origins off the surface. Without an occluder every point facing the light is lit; with
/// `through` false, light through the object is not looked for (one ray fewer).
pub fn arrival(
    light: &Light,
    x: DVec3,
    n: DVec3,
    occluder: Option<&dyn Solid>,
    offset: f64,
    through: bool,
) -> Arrival {
    let (e, l, dist) = light.arriving(x);
    if e.iter().all(|&v| v == 0.0) {
        return Arrival::Dark;
    }
    let mu = n.dot(l);
    let Some(solid) = occluder else {
        return if mu > 0.0 {
            Arrival::Lit {
                irradiance: e,
                mu_i: mu,
            }
        } else {
            Arrival::Dark
        };
    };
    if mu > 0.0 && !solid.occluded(x + n * offset, l, dist) {
        return Arrival::Lit {
            irradiance: e,
            mu_i: mu,
        };
    }
    if !through {
        return Arrival::Dark;
    }
    // From just inside towards the light: the first crossing leaves the object where the beam
    // came in, if it is the light's side of the object and nothing shades it.
    let origin = x - n * offset;
    match solid.ray_hit(origin, l, dist) {
        Some((t, normal)) if normal.dot(l) > 0.0 => {
            let entry = origin + l * t;
            if solid.occluded(entry + normal * offset, l, dist - t) {
                return Arrival::Dark;
            }
            let (e_entry, _, _) = light.arriving(entry);
            Arrival::Behind {
                irradiance: e_entry,
                entry,
                normal,
                mu_i: normal.dot(l),
                distance: t,
            }
        }
        _ => Arrival::Dark,
    }
}

/// Radiance of an environment arriving from direction `d` (clamped at zero: a truncated SH
/// expansion can dip below it). Mirrors `shade_mesh.frag`'s `sh_radiance`.
pub fn environment_radiance(env: &Environment, d: DVec3) -> [f64; 3] {
    match env {
        Environment::None => [0.0; 3],
        Environment::Constant(l) => *l,
        Environment::SphericalHarmonics(c) => std::array::from_fn(|ch| {
            let k = |i: usize| c[i][ch];
            let v = k(0) * 0.282_095
                + 0.488_603 * (k(1) * d.y + k(2) * d.z + k(3) * d.x)
                + 1.092_548 * (k(4) * d.x * d.y + k(5) * d.y * d.z + k(7) * d.x * d.z)
                + 0.315_392 * k(6) * (3.0 * d.z * d.z - 1.0)
                + 0.546_274 * k(8) * (d.x * d.x - d.y * d.y);
            v.max(0.0)
        }),
    }
}

/// Azimuths per incident cosine when an SH environment is integrated as beams.
const ENV_AZIMUTHS: usize = 8;

/// The environment as beams: per quadrature cosine mu_i, the surface irradiance it brings
/// (pi w L averaged over the azimuth), for the normal `n`.
pub fn environment_beams(env: &Environment, n: DVec3) -> Vec<(f64, [f64; 3])> {
    let quadrature = diffuse_quadrature();
    match env {
        Environment::None => Vec::new(),
        Environment::Constant(l) => quadrature
            .iter()
            .map(|&(mu, w)| (mu, l.map(|v| PI * w * v)))
            .collect(),
        Environment::SphericalHarmonics(_) => {
            let (t, b) = tangent_frame(n);
            quadrature
                .iter()
                .map(|&(mu, w)| {
                    let sin = (1.0 - mu * mu).max(0.0).sqrt();
                    let mut mean = [0.0; 3];
                    for a in 0..ENV_AZIMUTHS {
                        let phi = 2.0 * PI * (a as f64 + 0.5) / ENV_AZIMUTHS as f64;
                        let d = n * mu + (t * phi.cos() + b * phi.sin()) * sin;
                        let l = environment_radiance(env, d);
                        for c in 0..3 {
                            mean[c] += l[c] / ENV_AZIMUTHS as f64;
                        }
                    }
                    (mu, mean.map(|v| PI * w * v))
                })
                .collect()
        }
    }
}

/// Per channel, a beam's (incidence cosine, surface irradiance factor replacing mu_i in E mu_i,
/// the particular solution's curvature H / sigma_t' ([`beam_particular_curved`]), its lateral
/// correction dK ([`lateral_correction`])).
type ChannelBeams = [(f64, f64, f64, f64); 3];
/// [`SourceModel::at_with`]'s beam: (out, channel, optics, refraction, surface irradiance,
/// attenuation, alignment of its entry normal with the node's, lit here, (curvature H /
/// sigma_t', lateral dK)).
type AddBeam<'f> =
    dyn Fn(&mut LocalSource, usize, Optics, Refraction, f64, f64, f64, bool, (f64, f64)) + 'f;

/// The source terms of a scene for one material, transport model and occluder.
pub struct SourceModel<'a> {
    pub scene: &'a Scene,
    pub material: &'a MaterialField,
    pub occluder: Option<&'a dyn Solid>,
    pub transport: Transport,
    pub boundary: Boundary,
    /// Ray origins are lifted this far off the surface (mm).
    pub offset: f64,
}

impl<'a> SourceModel<'a> {
    pub fn new(
        scene: &'a Scene,
        material: &'a MaterialField,
        occluder: Option<&'a dyn Solid>,
        transport: Transport,
        offset: f64,
    ) -> Self {
        Self {
            scene,
            material,
            occluder,
            transport,
            boundary: Boundary::new(material.eta(), transport.exit),
            offset,
        }
    }

    /// Whether lights enter as beams (particular solutions) rather than as a boundary flux.
    fn beams(&self) -> bool {
        self.transport.source != Source::BoundaryFlux
    }

    /// The source's particular solution (gain, refraction) and the share r of its flux part: the
    /// first collision as refracted (1, r, 1); the second collision fitted to both moments
    /// ([`second_collision_fit`]).
    fn fitted(&self, o: Optics, r: Refraction) -> (f64, Refraction, f64) {
        match self.transport.source {
            Source::SecondCollision => {
                let f = second_collision_fit(o, r.mu_t, self.boundary.eta, self.boundary.h(o));
                (f.gain, Refraction { mu_t: f.mu_e, ..r }, f.ratio)
            }
            _ => (1.0, r, 1.0),
        }
    }

    /// Distance inside the object from `x` along the refracted beam direction `w` (pointing in),
    /// to the far face; infinite without an occluder or when no face is met.
    fn wall_thickness(&self, x: DVec3, n: DVec3, w: DVec3) -> f64 {
        self.occluder
            .and_then(|s| s.ray_hit(x - n * self.offset, w, f64::INFINITY))
            .map_or(f64::INFINITY, |(t, _)| t)
    }

    /// Mean sigma_t' per channel along the segment from `a` to `b` (midpoint rule; exact for a
    /// homogeneous material).
    fn mean_sigma_t(&self, a: DVec3, b: DVec3) -> [f64; 3] {
        if let MaterialField::Homogeneous(m) = self.material {
            return std::array::from_fn(|c| m.sigma_s[c] + m.sigma_a[c]);
        }
        let mut sum = [0.0; 3];
        for k in 0..DEPTH_SAMPLES {
            let p = a.lerp(b, (k as f64 + 0.5) / DEPTH_SAMPLES as f64);
            let c = self.material.sample(p);
            for ch in 0..3 {
                sum[ch] += (c.sigma_s[ch] + c.sigma_a[ch]) / DEPTH_SAMPLES as f64;
            }
        }
        sum
    }

    /// A light reaching surface point `x` directly with irradiance `irradiance` (per channel,
    /// normal to the beam) and per channel (incidence cosine, surface irradiance factor): (mu_i,
    /// mu_i) as it arrives, or [`upstream_beam`]'s (mu_up, irradiance).
    #[allow(clippy::too_many_arguments)]
    fn lit_light(
        &self,
        out: &mut LocalSource,
        add_beam: &AddBeam,
        light: &Light,
        x: DVec3,
        n: DVec3,
        here: &Coefficients,
        irradiance: [f64; 3],
        beams: ChannelBeams,
    ) {
        let eta = self.boundary.eta;
        let thin =
            self.beams() && self.transport.thin_wall_mfp > 0.0 && self.occluder.is_some() && {
                let (_, l, _) = light.arriving(x);
                let w = super::transport::refract_inward(-l, n, eta);
                let t = self.wall_thickness(x, n, w);
                let sigma_t = (0..3)
                    .map(|c| here.sigma_s[c] + here.sigma_a[c])
                    .fold(f64::INFINITY, f64::min);
                sigma_t * t < self.transport.thin_wall_mfp
            };
        for ch in 0..3 {
            let (mu_i, factor, curvature, lateral) = beams[ch];
            let r = Refraction::new(eta, mu_i);
            let irr = irradiance[ch] * factor;
            if self.beams() && !thin {
                // Near the particular solution's resonance part of the light
                // enters as the boundary flux (transport::beam_share).
                let o = Optics::channel_with(here, ch, self.material.diffusion());
                let (_, fit, ratio) = self.fitted(o, r);
                let share = beam_share(o, fit.mu_t);
                add_beam(
                    out,
                    ch,
                    o,
                    r,
                    irr * share,
                    1.0,
                    1.0,
                    true,
                    (curvature, lateral),
                );
                // The second-collision source scales its flux part too (the
                // once-scattered light is single scattering's, added whole).
                out.q_flux[ch] += ratio * irr * (1.0 - share) * r.t_i;
                out.transmitted[ch] += irr * (1.0 - share) * r.t_i;
            } else {
                out.q_flux[ch] += irr * r.t_i;
                out.transmitted[ch] += irr * r.t_i;
            }
        }
    }

    /// The light the first collisions below `x` carry from upstream ([`upstream_beam`]) when
    /// `transport.upstream_beam` is on: the curvature along the light's tangent from the
    /// surface one mean free path upstream (a probe ray along -n) or the baked one `given`, its
    /// visibility there (the node's own where it faces the light). `None`: off, too far past the
    /// terminator, or no curvature given and no surface found (the node's usual arrival applies).
    fn upstream(
        &self,
        light: &Light,
        x: DVec3,
        n: DVec3,
        here: &Coefficients,
        given: Option<SurfaceCurvature>,
    ) -> Option<([f64; 3], ChannelBeams)> {
        if !(self.transport.upstream_beam && self.beams()) {
            return None;
        }
        let (e, l, _) = light.arriving(x);
        let mu = n.dot(l);
        if mu <= -UPSTREAM_SHIFT_LIMIT || e.iter().all(|&v| v == 0.0) {
            return None;
        }
        let along = l - n * mu;
        let t = if along.length() > 1e-9 {
            along.normalize()
        } else {
            tangent_frame(n).0
        };
        let sigma_t: [f64; 3] = std::array::from_fn(|c| here.sigma_s[c] + here.sigma_a[c]);
        let mean_free_path = 3.0 / (sigma_t[0] + sigma_t[1] + sigma_t[2]).max(1e-12);
        let probe = x + (t + n) * mean_free_path;
        // A given curvature (the baked one the GPU reads) replaces the probe's; the probe's
        // surface point, where found, is where visibility is tested past the terminator.
        let probed = self
            .occluder
            .and_then(|solid| solid.ray_hit(probe, -n, 3.0 * mean_free_path));
        let (curvature, at, n_up) = match (given, probed) {
            (Some(k), Some((hit, n_up))) => (k, probe - n * hit, n_up),
            (Some(k), None) => (
                k,
                x + t * mean_free_path,
                (n + t * (k.along(t) * mean_free_path)).normalize_or(n),
            ),
            // The probe measures the curvature along t only: taken as the mean as well.
            (None, Some((hit, n_up))) => (
                SurfaceCurvature::umbilic((n_up - n).dot(t) / mean_free_path),
                probe - n * hit,
                n_up,
            ),
            (None, None) => return None,
        };
        // Without an occluder nothing shadows (the GPU's unshadowed lights alike).
        let lit = if mu > 0.0 {
            matches!(
                arrival(light, x, n, self.occluder, self.offset, false),
                Arrival::Lit { .. }
            )
        } else {
            // Past the terminator: a shadow ray from upstream (the GPU's shadow-map lookup there),
            // whatever the upstream normal's cosine (the shift's factor decides what arrives).
            let (_, l_up, dist) = light.arriving(at);
            self.occluder
                .is_none_or(|solid| !solid.occluded(at + n_up * self.offset, l_up, dist))
        };
        if !lit {
            return None;
        }
        let eta = self.boundary.eta;
        let curved = self.transport.curved_particular;
        // lateral_correction's curvatures: along the beam, or every direction's mean at the pole.
        let g = (
            curvature.squared(),
            if along.length() > 1e-9 {
                curvature.squared_along(t)
            } else {
                curvature.squared()
            },
        );
        let beams: ChannelBeams = std::array::from_fn(|c| {
            let b = upstream_beam_with(mu, curvature, t, sigma_t[c], eta, curved);
            let o = Optics::channel_with(here, c, self.material.diffusion());
            // The node's particular solution (K, beta) as lit_light makes it, for cosine m.
            let at = |m: f64| {
                let b = upstream_beam(m, curvature, t, sigma_t[c], eta);
                if b.irradiance <= 0.0 {
                    return (0.0, 0.0);
                }
                let r = Refraction::new(eta, b.mu_up);
                let (gain, fit, _) = self.fitted(o, r);
                let irr = e[c] * b.irradiance * beam_share(o, fit.mu_t);
                beam_particular_curved(o, fit, irr, gain, b.curvature)
            };
            let lateral = if curved && b.irradiance > 0.0 {
                curvature.umbilic_share() * lateral_correction(o, mu, b.curvature, g, at)
            } else {
                0.0
            };
            (b.mu_up, b.irradiance, b.curvature, lateral)
        });
        // Beyond its reach past the terminator the node keeps its usual arrival (continuation).
        beams
            .iter()
            .any(|&(_, f, _, _)| f > 0.0)
            .then_some((e, beams))
    }

    /// The sources at surface point `x` with outward normal `n`, the local coefficients `here`
    /// and the extrapolation length `h` = 2 A D of its Robin row, per channel.
    pub fn at_with(&self, x: DVec3, n: DVec3, here: &Coefficients, h: [f64; 3]) -> LocalSource {
        self.at_node(x, n, here, h, None)
    }

    /// [`Self::at_with`] at a surface node whose curvature `curvature` is known (the baked
    /// one, `quadgraph::surface_samples::surface_node_curvatures`): the upstream beam
    /// reads it instead of probing the surface (`None`: probed).
    pub fn at_node(
        &self,
        x: DVec3,
        n: DVec3,
        here: &Coefficients,
        h: [f64; 3],
        curvature: Option<SurfaceCurvature>,
    ) -> LocalSource {
        let eta = self.boundary.eta;
        let mut out = LocalSource::default();
        // Beam of surface irradiance irr (per channel) refracted as r with the coefficients `o`
        // at its entry; attenuation exp(-tau) and the cosine between its entry normal and n.
        let add_beam = |out: &mut LocalSource,
                        ch: usize,
                        o: Optics,
                        r: Refraction,
                        irr: f64,
                        attenuation: f64,
                        alignment: f64,
                        lit_here: bool,
                        (curvature, lateral): (f64, f64)| {
            let (gain, fit, _) = self.fitted(o, r);
            let (k, beta) = beam_particular_curved(o, fit, irr, gain, curvature);
            let k = k + lateral;
            out.phi_p[ch] += k * attenuation;
            out.dphi_p[ch] += -beta * k * attenuation * alignment;
            if lit_here {
                let p = irr * r.t_i;
                out.transmitted[ch] += p;
                out.absorbed[ch] += (1.0 - o.albedo()) * p + o.sigma_a * k / beta;
            }
        };
        for light in &self.scene.lights {
            if let Some((irradiance, beams)) = self.upstream(light, x, n, here, curvature) {
                self.lit_light(&mut out, &add_beam, light, x, n, here, irradiance, beams);
                continue;
            }
            match arrival(
                light,
                x,
                n,
                self.occluder,
                self.offset,
                self.beams() && self.transport.continuation,
            ) {
                Arrival::Dark => {}
                Arrival::Lit { irradiance, mu_i } => {
                    self.lit_light(
                        &mut out,
                        &add_beam,
                        light,
                        x,
                        n,
                        here,
                        irradiance,
                        [(mu_i, mu_i, 0.0, 0.0); 3],
                    );
                }
                Arrival::Behind {
                    irradiance,
                    entry,
                    normal,
                    mu_i,
                    distance,
                } => {
                    if !(self.beams() && self.transport.continuation) || mu_i <= 0.0 {
                        continue;
                    }
                    let r = Refraction::new(eta, mu_i);
                    let at_entry = self.material.sample(entry - normal * self.offset);
                    let sigma_t = self.mean_sigma_t(x, entry);
                    // The fallback for thin walls sends the near face's light in as a flux:
                    // nothing continues to the far face then.
                    let min_sigma_t = (0..3).map(|c| sigma_t[c]).fold(f64::INFINITY, f64::min);
                    if self.transport.thin_wall_mfp > 0.0
                        && min_sigma_t * distance * mu_i / r.mu_t.max(1e-6)
                            < self.transport.thin_wall_mfp
                    {
                        continue;
                    }
                    let alignment = n.dot(normal);
                    for ch in 0..3 {
                        // Jensen's refraction correction: the refracted path to the same depth
                        // below the entry plane is distance mu_i / mu_t.
                        let tau = sigma_t[ch] * distance * mu_i / r.mu_t.max(1e-6);
                        if tau > MAX_OPTICAL_DEPTH {
                            continue;
                        }
                        let o = Optics::channel_with(&at_entry, ch, self.material.diffusion());
                        let irr = irradiance[ch] * mu_i;
                        add_beam(
                            &mut out,
                            ch,
                            o,
                            r,
                            irr,
                            (-tau).exp(),
                            alignment,
                            false,
                            (0.0, 0.0),
                        );
                    }
                }
            }
        }
        let env = &self.scene.environment;
        if *env != Environment::None {
            if self.beams()
                && self.boundary.exit == ExitQuery::Moments
                && self.transport.environment_beams
            {
                self.beams_into(&mut out, here, &environment_beams(env, n), false);
            } else {
                let e = env.irradiance(n);
                let t = self.boundary.diffuse_transmittance();
                for ch in 0..3 {
                    out.q_flux[ch] += e[ch] * t;
                    out.transmitted[ch] += e[ch] * t;
                }
            }
        }
        for ch in 0..3 {
            out.rhs[ch] =
                self.boundary.flux_gain * out.q_flux[ch] - (out.phi_p[ch] - h[ch] * out.dphi_p[ch]);
        }
        out
    }

    /// Light arriving from many directions (the environment, or light that left the object
    /// elsewhere: the bounce), as beams of (cosine mu_i, surface irradiance per channel): particular
    /// solutions with beams (`first_collision`: gain 1 whatever the source model, for light whose
    /// single scattering is not added separately), a boundary flux otherwise. Unshadowed.
    pub fn diffuse_beams(
        &self,
        here: &Coefficients,
        h: [f64; 3],
        beams: &[(f64, [f64; 3])],
        first_collision: bool,
    ) -> LocalSource {
        let mut out = LocalSource::default();
        if self.beams() && self.boundary.exit == ExitQuery::Moments {
            self.beams_into(&mut out, here, beams, first_collision);
        } else {
            for &(mu, irr) in beams {
                let t = Refraction::new(self.boundary.eta, mu).t_i;
                for ch in 0..3 {
                    out.q_flux[ch] += irr[ch] * t;
                    out.transmitted[ch] += irr[ch] * t;
                }
            }
        }
        for ch in 0..3 {
            out.rhs[ch] =
                self.boundary.flux_gain * out.q_flux[ch] - (out.phi_p[ch] - h[ch] * out.dphi_p[ch]);
        }
        out
    }

    fn beams_into(
        &self,
        out: &mut LocalSource,
        here: &Coefficients,
        beams: &[(f64, [f64; 3])],
        first_collision: bool,
    ) {
        for &(mu, irr) in beams {
            if mu <= 0.0 {
                continue;
            }
            let r = Refraction::new(self.boundary.eta, mu);
            for ch in 0..3 {
                let o = Optics::channel_with(here, ch, self.material.diffusion());
                let (gain, fit, _) = if first_collision {
                    (1.0, r, 1.0)
                } else {
                    self.fitted(o, r)
                };
                let (k, beta) = beam_particular(o, fit, irr[ch], gain);
                let p = irr[ch] * r.t_i;
                out.phi_p[ch] += k;
                out.dphi_p[ch] -= beta * k;
                out.transmitted[ch] += p;
                out.absorbed[ch] += (1.0 - o.albedo()) * p + o.sigma_a * k / beta;
            }
        }
    }

    /// [`Self::at_with`] with the material sampled at `x` and its own extrapolation length.
    pub fn at(&self, x: DVec3, n: DVec3) -> LocalSource {
        let here = self.material.sample(x);
        let h = std::array::from_fn(|c| {
            self.boundary
                .h(Optics::channel_with(&here, c, self.material.diffusion()))
        });
        self.at_with(x, n, &here, h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::Material;
    use crate::mesh::shapes::Shape;

    /// The quadrature's own error on the sphere's transmitted power, relative.
    const POWER_TOLERANCE: f64 = 0.01;

    /// A marble sphere lit along -z (eta 1): with `upstream_beam` a node just past the terminator
    /// gets light (its first collisions come from beams that entered upstream), one on the lit
    /// side near it more than its own cosine, and the sphere's transmitted power stays pi R^2 E.
    #[test]
    fn upstream_beam_lights_past_the_terminator_and_keeps_the_power() {
        let radius = 10.0;
        let sphere = Shape::Sphere { radius };
        let mut marble = Material::preset("marble").expect("preset");
        marble.eta = 1.0;
        let field = MaterialField::Homogeneous(marble);
        let e = 5.0;
        let scene = Scene {
            lights: vec![Light::Directional {
                direction: -DVec3::Z,
                irradiance: [e; 3],
            }],
            environment: Environment::None,
        };
        let model = |upstream_beam: bool| {
            let transport = Transport {
                upstream_beam,
                ..Transport::second_collision()
            };
            SourceModel::new(&scene, &field, Some(&sphere), transport, 1e-6)
        };
        let at = |model: &SourceModel, mu: f64| {
            let n = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            model.at(n * radius, n).transmitted
        };
        let (planar, upstream) = (model(false), model(true));
        assert_eq!(at(&planar, -0.02), [0.0; 3]);
        assert!(at(&upstream, -0.02).iter().all(|&t| t > 0.0));
        assert!(at(&upstream, 0.05)[0] > at(&planar, 0.05)[0]);
        // Far past the terminator nothing arrives either way.
        assert_eq!(at(&upstream, -0.3), [0.0; 3]);
        const N: usize = 4000;
        let power = |m: &SourceModel| -> f64 {
            (0..N)
                .map(|i| -1.0 + 2.0 * (i as f64 + 0.5) / N as f64)
                .map(|mu| at(m, mu)[1] * 2.0 * PI * radius * radius * 2.0 / N as f64)
                .sum()
        };
        let input = PI * radius * radius * e;
        for m in [&planar, &upstream] {
            let p = power(m);
            assert!((p / input - 1.0).abs() < POWER_TOLERANCE, "{p} vs {input}");
        }
    }
}
