//! The cycle's smoother and schedule written as text (`translucent render --multigrid-cycle`,
//! `translucent bench --multigrid-cycle`): `key=value` items separated by commas, each replacing
//! one field of a [`MultigridParams`]; what is not named keeps its value.
//!
//! | key | field | example |
//! |---|---|---|
//! | `nu` | `pre_sweeps` / `post_sweeps` (Chebyshev degree on the finest level) | `nu=3/3` |
//! | `cnu` | `coarse_sweeps` (the levels between the finest and the coarsest) | `cnu=1` |
//! | `cheb` | `Smoother::Chebyshev { lower }` | `cheb=0.2` |
//! | `jacobi` | `Smoother::Jacobi { omega }` | `jacobi=0.8` |
//! | `ctol` | `coarse_tolerance` | `ctol=0.3` |
//! | `lanczos` | `power_iterations` (Lanczos steps for each level's lambda_max) | `lanczos=40` |
//! | `fmg` | `fmg_cycles` | `fmg=2` |
//! | `cap` | `max_cycles` (the GPU records at most 40 after the start) | `cap=8` |
//! | `fnu` | `fmg_sweeps` (the finest level's V-cycle in the full multigrid start) | `fnu=1/3` |
//! | `krylov` | `krylov` (0 or 1) | `krylov=0` |
//! | `psmooth` | `pattern_smoothing` (`S/STEPS`: `S / lambda_max` per Jacobi step on P's links) | `psmooth=0.67/2` |
//! | `interp` | `interpolation` (`shepard`, `linear`, `mixed`) | `interp=linear` |
//! | `warm` | `warm_start` (last, linear, quadratic) | `warm=last` |
//! | `drop` | `sparsify` (the coarse operators' drop threshold theta; 0: exact Galerkin) | `drop=0.05` |
//! | `lump` | `lumping` (`paths`, `diagonal`) | `lump=paths` |
//! | `pathw` | `path_weight` (each path edge's multiple of the dropped weight) | `pathw=2` |
//! | `dropfrom` | `sparsify_from_full` (`full`: each product from the exact operator; `sparse`) | `dropfrom=sparse` |
//! | `local` | `local_relaxation` (`RINGSxSWEEPS` or `off`) | `local=4x16` |
//! | `wcc` | `warm_corrections` (coarse-grid corrections after the local relaxation, 0-4) | `wcc=2` |
//!
//! ```
//! use translucent::solver::multigrid::MultigridParams;
//! let p = MultigridParams::gpu().with_cycle_spec("nu=3/3,cheb=0.2,fmg=2")?;
//! assert_eq!((p.pre_sweeps, p.post_sweeps, p.fmg_cycles), (3, 3, 2));
//! assert!(MultigridParams::gpu().with_cycle_spec("nu=3").is_err());
//! let local = MultigridParams::gpu().with_cycle_spec("local=2x8")?.local_relaxation;
//! assert_eq!(local.map(|l| (l.rings, l.sweeps)), Some((2, 8)));
//! assert!(MultigridParams::gpu().with_cycle_spec("local=off")?.local_relaxation.is_none());
//! assert!(MultigridParams::gpu().with_cycle_spec("local=4").is_err());
//! assert!(MultigridParams::gpu().with_cycle_spec("local=4x0").is_err());
//! assert_eq!(MultigridParams::gpu().with_cycle_spec("wcc=2")?.warm_corrections, 2);
//! assert!(MultigridParams::gpu().with_cycle_spec("wcc=5").is_err());
//! # Ok::<(), translucent::solver::SolverError>(())
//! ```

use super::{Interpolation, MultigridParams, Smoother};
use crate::solver::SolverError;

impl MultigridParams {
    /// `self` with the fields `spec` names replaced (see the module doc), validated.
    pub fn with_cycle_spec(&self, spec: &str) -> Result<Self, SolverError> {
        let bad = |problem: String| SolverError::BadParameter {
            name: "multigrid cycle",
            problem,
        };
        let mut p = self.clone();
        for item in spec.split(',').map(str::trim).filter(|i| !i.is_empty()) {
            let (key, value) = item
                .split_once('=')
                .ok_or_else(|| bad(format!("`{item}` is not key=value")))?;
            let number = |v: &str| {
                v.parse::<f64>()
                    .map_err(|_| bad(format!("{key}: `{v}` is not a number")))
            };
            let count = |v: &str| {
                v.parse::<u32>()
                    .map_err(|_| bad(format!("{key}: `{v}` is not a count")))
            };
            match key {
                "nu" => {
                    let (pre, post) = value
                        .split_once('/')
                        .ok_or_else(|| bad(format!("nu: `{value}` is not PRE/POST")))?;
                    p.pre_sweeps = count(pre)?;
                    p.post_sweeps = count(post)?;
                }
                "fnu" => {
                    let (pre, post) = value
                        .split_once('/')
                        .ok_or_else(|| bad(format!("fnu: `{value}` is not PRE/POST")))?;
                    p.fmg_sweeps = Some((count(pre)?, count(post)?));
                }
                "psmooth" => {
                    let (s, steps) = value
                        .split_once('/')
                        .ok_or_else(|| bad(format!("psmooth: `{value}` is not S/STEPS")))?;
                    p.pattern_smoothing = Some((number(s)?, count(steps)?));
                }
                "cnu" => p.coarse_sweeps = Some(count(value)?),
                "cheb" => {
                    p.smoother = Smoother::Chebyshev {
                        lower: number(value)?,
                    }
                }
                "jacobi" => {
                    p.smoother = Smoother::Jacobi {
                        omega: number(value)?,
                    }
                }
                "ctol" => p.coarse_tolerance = number(value)?,
                "lanczos" => p.power_iterations = count(value)?,
                "fmg" => p.fmg_cycles = count(value)?,
                "cap" => p.max_cycles = count(value)?,
                "krylov" => {
                    p.krylov = match value {
                        "0" => false,
                        "1" => true,
                        v => return Err(bad(format!("krylov: `{v}` is not 0 or 1"))),
                    }
                }
                "interp" => {
                    p.interpolation = match value {
                        "shepard" => Interpolation::Shepard,
                        "linear" => Interpolation::Linear,
                        "mixed" => Interpolation::Mixed,
                        v => {
                            return Err(bad(format!(
                                "interp: `{v}` is not shepard, linear or mixed"
                            )))
                        }
                    }
                }
                "drop" => {
                    let theta = number(value)?;
                    p.sparsify = (theta != 0.0).then_some(theta);
                }
                "lump" => {
                    p.lumping = value.parse().map_err(|_| {
                        bad(format!("lump: `{value}` is not paths or diagonal"))
                    })?
                }
                "pathw" => p.path_weight = number(value)?,
                "dropfrom" => {
                    p.sparsify_from_full = match value {
                        "full" => true,
                        "sparse" => false,
                        v => return Err(bad(format!("dropfrom: `{v}` is not full or sparse"))),
                    }
                }
                "warm" => {
                    p.warm_start = value.parse().map_err(|_| {
                        bad(format!("warm: `{value}` is not last, linear or quadratic"))
                    })?
                }
                "local" => {
                    p.local_relaxation = match value {
                        "off" => None,
                        v => Some(v.parse().map_err(|_| {
                            bad(format!("local: `{v}` is not off or RINGSxSWEEPS (e.g. 4x16)"))
                        })?),
                    }
                }
                "wcc" => p.warm_corrections = count(value)?,
                k => {
                    return Err(bad(format!(
                        "unknown key `{k}` (nu, cnu, cheb, jacobi, ctol, lanczos, fmg, fnu, krylov, interp, psmooth, warm, drop, lump, pathw, dropfrom, local, wcc)"
                    )))
                }
            }
        }
        p.validate()?;
        Ok(p)
    }
}
