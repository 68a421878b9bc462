//! The sweep axes: comma-separated lists parsed into the cross product of configurations.

use glam::DQuat;
use translucent::frame::BounceMode;
use translucent::scene::{ExitLobe, Light};
use translucent::solver::gpu::{HeterogeneousWeights, Precision};
use translucent::solver::Scheme;

use super::*;

/// One swept setting.
#[derive(Clone, Debug)]
pub(super) struct Config {
    pub(super) scheme: Scheme,
    pub(super) precision: Precision,
    pub(super) warm: bool,
    pub(super) multigrid: bool,
    pub(super) cap: u32,
    pub(super) tolerance: f32,
    pub(super) weights: HeterogeneousWeights,
    /// The multigrid schedule's parameters (`MultigridParams::gpu` with `--multigrid-cycle`).
    pub(super) cycle: translucent::solver::multigrid::MultigridParams,
    /// One bounce between display vertices (`--bounce`; after the solve: J+ of the surface
    /// nodes, which errors (a) and (b) read, is the same either way).
    pub(super) bounce: BounceMode,
    /// The exit radiance's angular shape (`--exit-lobe`; shading only).
    pub(super) exit_lobe: ExitLobe,
}

/// The lists, parsed and checked before anything runs.
pub(super) struct Sweep {
    pub(super) k: Vec<f64>,
    pub(super) levels: Vec<u32>,
    pub(super) resolution: Vec<u32>,
    pub(super) schemes: Vec<Scheme>,
    pub(super) precisions: Vec<Precision>,
    pub(super) starts: Vec<bool>,
    /// `true`: multigrid.
    pub(super) schedules: Vec<bool>,
    pub(super) iterations: Vec<u32>,
    pub(super) tolerances: Vec<f32>,
    pub(super) weights: HeterogeneousWeights,
    pub(super) cycle: translucent::solver::multigrid::MultigridParams,
    pub(super) bounces: Vec<BounceMode>,
    pub(super) exit_lobes: Vec<ExitLobe>,
    /// `--warm-probe`.
    pub(super) warm_probe: bool,
}

pub(super) fn list<T>(
    option: &'static str,
    text: &str,
    parse: impl Fn(&str) -> Result<T, String>,
) -> Result<Vec<T>, BenchError> {
    let bad = |item: &str, problem: String| BenchError::BadList {
        option,
        list: text.to_string(),
        item: item.to_string(),
        problem,
    };
    let mut out = Vec::new();
    for item in text.split(',') {
        let item = item.trim();
        if item.is_empty() {
            return Err(bad(item, "is empty (a stray comma?)".into()));
        }
        out.push(parse(item).map_err(|p| bad(item, p))?);
    }
    Ok(out)
}

pub(super) fn uint(min: u32, max: u32) -> impl Fn(&str) -> Result<u32, String> {
    move |s| {
        let v: u32 = s.parse().map_err(|_| "is not a whole number".to_string())?;
        if (min..=max).contains(&v) {
            Ok(v)
        } else {
            Err(format!("is outside {min}..={max}"))
        }
    }
}

pub(super) fn non_negative(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| "is not a number".to_string())?;
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err("must be a finite number >= 0".into())
    }
}

/// `--schedule` when not given: the library's (multigrid, [`super::DEFAULT_SCHEDULE`]) unless an
/// option only the cascade has is given, as `render` decides (`render::schedule_of`):
/// `--iterations` (the cascade's caps), fp16 in `--precision` (the cycles keep phi in fp32),
/// paper in `--scheme` (not symmetric, which the CG around the V-cycle assumes).
fn default_schedule(args: &BenchArgs) -> &'static str {
    let named = |list: &str, item: &str| list.split(',').any(|s| s.trim() == item);
    if args.iterations.is_some() || named(&args.precision, "fp16") || named(&args.scheme, "paper") {
        "cascade"
    } else {
        super::DEFAULT_SCHEDULE
    }
}

impl Sweep {
    pub(super) fn parse(args: &BenchArgs) -> Result<Sweep, BenchError> {
        let iterations = args
            .iterations
            .clone()
            .unwrap_or_else(|| translucent::defaults::CASCADE_ITERATIONS.to_string());
        let schedule = args
            .schedule
            .clone()
            .unwrap_or_else(|| default_schedule(args).to_string());
        let sweep = Sweep {
            warm_probe: args.warm_probe,
            k: list("-K", &args.k, non_negative)?,
            levels: list("--levels", &args.levels, uint(1, 8))?,
            resolution: list("--resolution", &args.resolution, uint(4, 512))?,
            schemes: list("--scheme", &args.scheme, |s| match s {
                "fv" => Ok(Scheme::Fv),
                "paper" => Ok(Scheme::Paper),
                _ => Err("is not a scheme (fv, paper)".into()),
            })?,
            precisions: list("--precision", &args.precision, |s| {
                s.parse::<Precision>()
                    .map_err(|_| "is not a precision (mixed, fp32, fp16)".to_string())
            })?,
            starts: list("--start", &args.start, |s| match s {
                "cold" => Ok(false),
                "warm" => Ok(true),
                _ => Err("is not a start (cold, warm)".into()),
            })?,
            schedules: list("--schedule", &schedule, |s| match s {
                "cascade" => Ok(false),
                "multigrid" => Ok(true),
                _ => Err("is not a schedule (cascade, multigrid)".into()),
            })?,
            iterations: list("--iterations", &iterations, uint(1, 1_000_000))?,
            tolerances: list("--tolerance", &args.tolerance, |s| {
                non_negative(s).map(|v| v as f32)
            })?,
            weights: args
                .heterogeneous_weights
                .parse()
                .map_err(|_| BenchError::BadOption {
                    option: "--heterogeneous-weights",
                    problem: format!("'{}' (derived or stored)", args.heterogeneous_weights),
                })?,
            bounces: list("--bounce", &args.bounce, |s| {
                s.parse::<BounceMode>()
                    .map_err(|_| "is not a bounce (off, local)".to_string())
            })?,
            exit_lobes: list("--exit-lobe", &args.scene.exit_lobe, |s| {
                s.parse::<ExitLobe>()
                    .map_err(|_| format!("is not an exit lobe ({})", ExitLobe::NAMES.join(", ")))
            })?,
            // The library's warm start unless the spec names another (`warm=last`).
            cycle: translucent::solver::multigrid::MultigridParams {
                warm_start: translucent::defaults::WARM_START,
                ..translucent::solver::multigrid::MultigridParams::gpu()
            }
            .with_cycle_spec(args.multigrid_cycle.as_deref().unwrap_or(""))
            .map_err(|e| BenchError::BadOption {
                option: "--multigrid-cycle",
                problem: e.to_string(),
            })?,
        };
        // The headless frame's profiler must hold every scope of the largest frame, or the
        // timings would silently leave out the last blocks.
        let max_levels = u64::from(*sweep.levels.iter().max().unwrap_or(&1));
        for &cap in &sweep.iterations {
            let scopes = max_levels * (2 * u64::from(cap.div_ceil(BLOCK)) + 2) + 8;
            if scopes > FRAME_SCOPES {
                return Err(BenchError::BadList {
                    option: "--iterations",
                    list: iterations.clone(),
                    item: cap.to_string(),
                    problem: format!(
                        "needs {scopes} timestamp scopes per frame with {max_levels} levels; the \
                         headless frame profiler holds {FRAME_SCOPES} (cap at most {})",
                        (FRAME_SCOPES - 8) / max_levels / 2 * u64::from(BLOCK) - u64::from(BLOCK)
                    ),
                });
            }
        }
        if args.repeats == 0 {
            return Err(BenchError::BadOption {
                option: "--repeats",
                problem: "0: time at least one frame".into(),
            });
        }
        if !args.warm_degrees.is_finite() {
            return Err(BenchError::BadOption {
                option: "--warm-degrees",
                problem: format!("{} is not finite", args.warm_degrees),
            });
        }
        Ok(sweep)
    }

    pub(super) fn configs(&self) -> Vec<Config> {
        let mut out = Vec::new();
        for &scheme in &self.schemes {
            for &precision in &self.precisions {
                for &warm in &self.starts {
                    for &multigrid in &self.schedules {
                        for &tolerance in &self.tolerances {
                            // The multigrid schedule has no iteration cap: one row per tolerance.
                            let caps = if multigrid {
                                &self.iterations[..1]
                            } else {
                                &self.iterations[..]
                            };
                            for &cap in caps {
                                for &bounce in &self.bounces {
                                    for &exit_lobe in &self.exit_lobes {
                                        out.push(Config {
                                            scheme,
                                            precision,
                                            warm,
                                            multigrid,
                                            cap,
                                            tolerance,
                                            weights: self.weights,
                                            cycle: self.cycle.clone(),
                                            bounce,
                                            exit_lobe,
                                        });
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
        out
    }
}

pub(super) fn scheme_name(s: Scheme) -> &'static str {
    match s {
        Scheme::Fv => "fv",
        Scheme::Paper => "paper",
    }
}

pub(super) fn precision_name(p: Precision) -> &'static str {
    match p {
        Precision::Mixed => "mixed",
        Precision::Fp32 => "fp32",
        Precision::Fp16 => "fp16",
    }
}

pub(super) fn rgb(option: &'static str, text: &str) -> Result<[f64; 3], BenchError> {
    let v = list(option, text, |s| {
        s.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| "is not a finite number >= 0".to_string())
    })?;
    v.try_into().map_err(|v: Vec<f64>| BenchError::BadOption {
        option,
        problem: format!("{text:?}: expected 3 numbers, got {}", v.len()),
    })
}

/// The lights turned by `degrees` about +Y through the origin (the previous frame of a warm start).
pub(super) fn turned(lights: &[Light], degrees: f64) -> Vec<Light> {
    let q = DQuat::from_rotation_y(degrees.to_radians());
    lights.iter().map(|l| l.rotated(q)).collect()
}

pub(super) fn dark(l: &Light) -> bool {
    match l {
        Light::Directional { irradiance: e, .. }
        | Light::Point { intensity: e, .. }
        | Light::Spot { intensity: e, .. } => e.iter().all(|&v| v == 0.0),
    }
}
