//! The error metrics (relative RMS against the exact discrete solution, the closed form, a
//! reference image) and the real-time / quality picks and Pareto front over the rows.

use std::path::{Path, PathBuf};

use anyhow::bail;
use translucent::material::MaterialField;
use translucent::solver::krylov;
use translucent::solver::operator::LevelOperator;
use translucent::solver::Scheme;
use translucent::vk::LinearImage;
use translucent::QuadGraph;

use super::*;

/// Relative RMS per channel and over all three; `None` where the reference is all zero.
pub(super) type Errors = [Option<f64>; 4];

pub(super) fn rel_rms(pairs: impl Iterator<Item = ([f64; 3], [f64; 3])>) -> Errors {
    let (mut d2, mut r2) = ([0.0f64; 3], [0.0f64; 3]);
    for (ours, reference) in pairs {
        for c in 0..3 {
            d2[c] += (ours[c] - reference[c]).powi(2);
            r2[c] += reference[c].powi(2);
        }
    }
    let ratio = |d: f64, r: f64| (r > 0.0).then(|| (d / r).sqrt());
    [
        ratio(d2[0], r2[0]),
        ratio(d2[1], r2[1]),
        ratio(d2[2], r2[2]),
        ratio(d2.iter().sum(), r2.iter().sum()),
    ]
}

/// A reference image and its object mask.
pub(super) struct Reference {
    pub(super) path: PathBuf,
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) rgb: Vec<[f64; 3]>,
    pub(super) mask: Vec<bool>,
    pub(super) mask_kind: &'static str,
}

impl Reference {
    pub(super) fn load(path: &Path) -> Result<Reference, BenchError> {
        let bad = |problem: String| BenchError::BadReference {
            path: path.to_path_buf(),
            problem,
        };
        let image = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |res, channels: &exr::prelude::RgbaChannels| {
                (
                    res.width(),
                    channels.3.is_some(),
                    vec![[0.0f64; 4]; res.width() * res.height()],
                )
            },
            |(w, _, buf), pos, (r, g, b, a): (f32, f32, f32, f32)| {
                buf[pos.y() * *w + pos.x()] =
                    [f64::from(r), f64::from(g), f64::from(b), f64::from(a)]
            },
        )
        .map_err(|e| bad(e.to_string()))?;
        let size = image.layer_data.size;
        let (_, has_alpha, pixels) = &image.layer_data.channel_data.pixels;
        if let Some(i) = pixels.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
            return Err(bad(format!(
                "pixel ({}, {}) is not finite",
                i % size.width(),
                i / size.width()
            )));
        }
        let (width, height) = (
            u32::try_from(size.width()).map_err(|_| bad("too wide".into()))?,
            u32::try_from(size.height()).map_err(|_| bad("too tall".into()))?,
        );
        if !(1..=4096).contains(&width) || !(1..=4096).contains(&height) {
            return Err(bad(format!(
                "{width}x{height}: expected 1..=4096 px a side"
            )));
        }
        // compare_exr.py's default mask: pixels the object covers fully (silhouette pixels,
        // where a rasterizer and a path tracer differ by construction, are left out).
        let mask: Vec<bool> = pixels
            .iter()
            .map(|p| match has_alpha {
                true => p[3] >= 0.999,
                false => p[..3].iter().any(|&v| v > 0.0),
            })
            .collect();
        if !mask.iter().any(|&m| m) {
            return Err(bad("no object pixels (alpha >= 0.999 or non-black)".into()));
        }
        Ok(Reference {
            path: path.to_path_buf(),
            width,
            height,
            rgb: pixels.iter().map(|p| [p[0], p[1], p[2]]).collect(),
            mask,
            mask_kind: if *has_alpha { "alpha" } else { "nonblack" },
        })
    }

    pub(super) fn error(&self, image: &LinearImage) -> Errors {
        rel_rms(
            image
                .pixels
                .iter()
                .zip(&self.rgb)
                .zip(&self.mask)
                .filter(|(_, &m)| m)
                .map(|((o, r), _)| ([o[0], o[1], o[2]].map(f64::from), *r)),
        )
    }
}

/// Discrete error (a) below which the iterations are done for real time: 1%, well under the
/// model's own error against path tracing (the RESULTS ptref section: 1.4-39%).
pub(super) const REALTIME: f64 = 1e-2;
/// ... and for the quality setting: 0.1%.
pub(super) const QUALITY: f64 = 1e-3;

/// (real-time, quality): the GPU rows whose solver error is within [`REALTIME`] and
/// [`QUALITY`] with the fewest node updates (a deterministic cost: on a loaded machine the
/// measured milliseconds of one configuration move by 2-4x), then the least solve time.
pub(super) fn picks(rows: &[Row]) -> (Option<usize>, Option<usize>) {
    let fastest_within = |limit: f64| {
        rows.iter()
            .enumerate()
            .filter(|(_, r)| r.solver_error[3].is_some_and(|e| e <= limit))
            .filter_map(|(i, r)| Some((i, r.node_updates.unwrap_or(0), r.solve_gpu_ms?)))
            .min_by(|a, b| a.1.cmp(&b.1).then(a.2.total_cmp(&b.2)))
            .map(|(i, _, _)| i)
    };
    (fastest_within(REALTIME), fastest_within(QUALITY))
}

/// Marks the GPU rows no other GPU row beats in both solve time and error.
pub(super) fn mark_pareto(rows: &mut [Row]) {
    let front = |rows: &[Row], error: &dyn Fn(&Row) -> Option<f64>| -> Vec<bool> {
        rows.iter()
            .map(|r| {
                let (Some(t), Some(e)) = (r.solve_gpu_ms, error(r)) else {
                    return false;
                };
                !rows.iter().any(|o| match (o.solve_gpu_ms, error(o)) {
                    (Some(to), Some(eo)) => to <= t && eo <= e && (to < t || eo < e),
                    _ => false,
                })
            })
            .collect()
    };
    let solver = front(rows, &|r| r.solver_error[3]);
    let image = front(rows, &|r| r.absolute());
    for (r, (d, i)) in rows.iter_mut().zip(solver.into_iter().zip(image)) {
        r.pareto_solver = d;
        r.pareto_image = i;
    }
}

/// Error (b): J+ against the sphere's uniform closed-form J+ = albedo q / (1 - F_dr) (`per_q` is
/// albedo / (1 - F_dr) per channel), with the reference's own q (uniform for a constant
/// environment).
pub(super) fn analytic_error(j_plus: &[[f64; 3]], q: &[[f64; 3]], per_q: &[f64; 3]) -> Errors {
    rel_rms(
        j_plus
            .iter()
            .zip(q)
            .map(|(j, q)| (*j, std::array::from_fn(|c| per_q[c] * q[c]))),
    )
}

/// Clamped J+ per finest surface node of the exact solution (to 1e-10) of the finest level's
/// system for the surface irradiance `q` (per surface node), starting from `phi`.
pub(super) fn exact_for_q(
    graph: &QuadGraph,
    field: &MaterialField,
    scheme: Scheme,
    q: &[[f64; 3]],
    phi: &[[f64; 3]],
) -> anyhow::Result<Vec<[f64; 3]>> {
    let level = graph.finest();
    let op = LevelOperator::build(level, field, scheme)?;
    let b = op.rhs(q);
    let mut phi = phi.to_vec();
    let report = krylov::solve(&op, &b, &mut phi, 1e-10, 100_000);
    if !report.converged {
        bail!("did not converge (relative residual {:?})", report.residual);
    }
    let inner = level.inner_count();
    Ok(q.iter()
        .enumerate()
        .map(|(s, q)| {
            std::array::from_fn(|c| {
                ((1.0 + 1.0 / op.a) * phi[inner + s][c] / 4.0 - q[c] / (1.0 + op.f_dr)).max(0.0)
            })
        })
        .collect())
}

pub(super) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}
