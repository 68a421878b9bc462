//! `translucent bench --warm-probe`: where a warm frame's start residual sits (issue 13).
//!
//! For each warm configuration the bench keeps the q the GPU gathered on every frame of the light
//! path (the untimed frames at -3, -2, -1 steps and the timed one). The probe solves each frame's
//! q exactly in f64 on the CPU [`Hierarchy`] (the GPU's operator in f64), forms the warm start
//! the GPU forms (`MultigridParams::warm_start` through those exact solutions), and prints:
//! - the start's relative residual `||f - K x0|| / ||f||` (the stopping rule's quantity);
//! - how concentrated it is: the share of `||r||^2` on the top 10, 100, 1000 nodes and the node
//!   counts holding half and 90% of it; the share on the nodes where q jumps (the extrapolated q
//!   misses the frame's by more than a tenth of its own value: shadow edges) and their rings;
//! - the GPU's local relaxation (`--multigrid-cycle local=RINGSxSWEEPS`) mirrored in f64 at a
//!   few sizes: nodes listed, the residual it leaves, the CG cycle's work units after it;
//! - the best any local fix could do: the residual on the jump nodes solved exactly, per
//!   extrapolation order (0, 1, 2), then the cycle's work units;
//! - what the f64 CPU cycle needs cold and warm (work units as the GPU counts them).
//!
//! ```text
//! translucent bench --shape torus --size-mm 50 --material skimmilk --width 256 --height 256 \
//!     --resolution 29 --levels 3 -K 1 --iterations 2000 --tolerance 1e-4 --schedule multigrid \
//!     --start warm --warm-degrees 3 --repeats 1 --warm-probe --out b
//! ```

use translucent::material::MaterialField;
use translucent::solver::multigrid::{
    Hierarchy, MultigridParams, SparseOperator, Start, WarmStart,
};
use translucent::solver::Scheme;
use translucent::QuadGraph;

/// Per-node RGB values.
type Rgb = [f64; 3];

/// The exact solves' relative residual (far below any tolerance the bench sweeps).
const EXACT_TOLERANCE: f64 = 1e-11;
/// A surface node's q "jumps" where the extrapolated q misses the frame's by more than this
/// fraction of the frame's largest q (a shadow edge crossing it, not the smooth turn).
const JUMP_FRACTION: f64 = 0.02;

/// Sum over channels of squares per node.
fn energy(r: &[Rgb]) -> Vec<f64> {
    r.iter().map(|v| v.iter().map(|x| x * x).sum()).collect()
}

fn rel(r: &[Rgb], f: &[Rgb]) -> f64 {
    (0..3)
        .map(|c| {
            let rn: f64 = r.iter().map(|v| v[c] * v[c]).sum::<f64>().sqrt();
            let fn_: f64 = f.iter().map(|v| v[c] * v[c]).sum::<f64>().sqrt();
            if fn_ > 0.0 {
                rn / fn_
            } else {
                rn
            }
        })
        .fold(0.0, f64::max)
}

/// The warm start of `order` through `solutions` (oldest first).
fn extrapolate(solutions: &[Vec<Rgb>], order: u32) -> Vec<Rgb> {
    let c = WarmStart::coefficients(order);
    let n = solutions[0].len();
    (0..n)
        .map(|i| {
            std::array::from_fn(|ch| {
                c.iter()
                    .enumerate()
                    .map(|(k, &w)| f64::from(w) * solutions[solutions.len() - 1 - k][i][ch])
                    .sum()
            })
        })
        .collect()
}

/// The GPU's local relaxation in f64 (`multigrid/local.comp`): the nodes whose residual exceeds
/// `tolerance ||f||` in a channel, `rings` of neighbours, `sweeps` damped block-Jacobi sweeps on
/// them; the relaxed x and the listed count.
fn local_relaxation(
    op: &SparseOperator,
    f: &[Rgb],
    x0: &[Rgb],
    tolerance: f64,
    rings: u32,
    sweeps: u32,
) -> (Vec<Rgb>, usize) {
    /// `LOCAL_OMEGA` of the GPU's.
    const OMEGA: f64 = 0.8;
    let n = f.len();
    let fnorm: [f64; 3] =
        std::array::from_fn(|c| f.iter().map(|v| v[c] * v[c]).sum::<f64>().sqrt());
    let mut r = vec![[0.0; 3]; n];
    op.residual(x0, f, &mut r);
    let mut set: Vec<usize> = (0..n)
        .filter(|&i| (0..3).any(|c| r[i][c].abs() > tolerance * fnorm[c]))
        .collect();
    let mut listed = vec![false; n];
    for &i in &set {
        listed[i] = true;
    }
    let mut begin = 0;
    for _ in 0..rings {
        let end = set.len();
        for k in begin..end {
            let i = set[k];
            for e in op.row_start[i]..op.row_start[i + 1] {
                let j = op.cols[e] as usize;
                if !listed[j] {
                    listed[j] = true;
                    set.push(j);
                }
            }
        }
        begin = end;
    }
    let mut x = x0.to_vec();
    for _ in 0..sweeps {
        op.residual(&x, f, &mut r);
        let steps: Vec<Rgb> = set.iter().map(|&i| op.block_solve(i, &r)).collect();
        for (&i, d) in set.iter().zip(steps) {
            for c in 0..3 {
                x[i][c] += OMEGA * d[c];
            }
        }
    }
    (x, set.len())
}

/// Prints the probe of one warm configuration: `qs` the gathered q of every frame, oldest
/// first, the timed frame last.
pub(super) fn probe(
    graph: &QuadGraph,
    field: &MaterialField,
    scheme: Scheme,
    cycle: &MultigridParams,
    tolerance: f64,
    qs: &[Vec<Rgb>],
) -> anyhow::Result<()> {
    let h = Hierarchy::build(graph, field, scheme, cycle)?;
    let exact_params = MultigridParams {
        tolerance: EXACT_TOLERANCE,
        max_cycles: 200,
        ..cycle.clone()
    };
    let fs: Vec<Vec<Rgb>> = qs.iter().map(|q| h.scaled_rhs(q)).collect();
    let xs: Vec<Vec<Rgb>> = fs
        .iter()
        .map(|f| h.solve(f, Start::Cold, &exact_params, &mut |_, _| {}).0)
        .collect();
    let (f, earlier) = (&fs[fs.len() - 1], &xs[..xs.len() - 1]);
    let level = graph.finest();
    let inner = level.inner_count();
    let op = &h.levels.last().expect("levels").operator;
    let n = f.len();
    let order = cycle.warm_start.history().min(earlier.len() as u32 - 1);
    let x0 = extrapolate(earlier, order);
    let mut r = vec![[0.0; 3]; n];
    op.residual(&x0, f, &mut r);
    let e = energy(&r);
    let total: f64 = e.iter().sum();
    let mut sorted = e.clone();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let share = |k: usize| sorted.iter().take(k).sum::<f64>() / total;
    let holding = |frac: f64| {
        let mut acc = 0.0;
        sorted
            .iter()
            .position(|v| {
                acc += v;
                acc >= frac * total
            })
            .map_or(n, |p| p + 1)
    };
    println!(
        "warm probe: {n} finest nodes ({} surface), order {order}, start residual {:.3e}",
        level.surface_count(),
        rel(&r, f)
    );
    println!(
        "  share of ||r||^2: top 10 {:.3}, top 100 {:.3}, top 1000 {:.3}; nodes holding 50% {}, 90% {}; surface nodes {:.3}",
        share(10),
        share(100),
        share(1000),
        holding(0.5),
        holding(0.9),
        e[inner..].iter().sum::<f64>() / total
    );
    // The q the extrapolation implies (the same polynomial through the frames' q) against the
    // frame's: where a shadow edge crossed a node, not the smooth turn.
    let q_start = extrapolate(&qs[..qs.len() - 1], order);
    let q = &qs[qs.len() - 1];
    let q_max = q.iter().flatten().fold(0.0f64, |a, &b| a.max(b)).max(1e-30);
    let jumps: Vec<usize> = (0..q.len())
        .filter(|&s| (0..3).any(|c| (q[s][c] - q_start[s][c]).abs() > JUMP_FRACTION * q_max))
        .map(|s| inner + s)
        .collect();
    let mut marked = vec![false; n];
    for &i in &jumps {
        marked[i] = true;
    }
    let mut ring_shares = Vec::new();
    for _ in 0..3 {
        let m: f64 = (0..n).filter(|&i| marked[i]).map(|i| e[i]).sum();
        let count = marked.iter().filter(|&&v| v).count();
        ring_shares.push(format!("{count} nodes {:.3}", m / total));
        let next = marked.clone();
        for (i, _) in next.iter().enumerate().filter(|(_, &m)| m) {
            for k in op.row_start[i]..op.row_start[i + 1] {
                marked[op.cols[k] as usize] = true;
            }
        }
    }
    println!(
        "  q jumps (> {JUMP_FRACTION} of max q): {} surface nodes; share of ||r||^2 on them and 1, 2 rings: {}",
        jumps.len(),
        ring_shares.join(", ")
    );
    let params = MultigridParams {
        tolerance,
        ..cycle.clone()
    };
    let log = |c: &[translucent::solver::multigrid::CycleReport]| {
        c.iter()
            .map(|c| format!("{:.2e}", c.residual))
            .collect::<Vec<_>>()
            .join(" ")
    };
    // The GPU's local relaxation (`local.comp`) in f64, at a few sizes.
    let fnorm: [f64; 3] =
        std::array::from_fn(|c| f.iter().map(|v| v[c] * v[c]).sum::<f64>().sqrt());
    let marked = (0..n)
        .filter(|&i| (0..3).any(|c| r[i][c].abs() > tolerance * fnorm[c]))
        .count();
    println!("  nodes with |r_i| > tol ||f|| in a channel (marked): {marked}");
    let mut sizes = vec![(2, 4), (4, 16), (6, 16)];
    if let Some(l) = cycle.local_relaxation {
        sizes.retain(|&s| s != (l.rings, l.sweeps));
        sizes.insert(0, (l.rings, l.sweeps));
    }
    for (rings, sweeps) in sizes {
        let (x, listed) = local_relaxation(op, f, &x0, tolerance, rings, sweeps);
        let mut rr = vec![[0.0; 3]; n];
        op.residual(&x, f, &mut rr);
        let (_, w) = h.solve(f, Start::Warm(&x), &params, &mut |_, _| {});
        println!(
            "  local {rings}x{sweeps}: {listed} nodes, residual {:.3e}, then {:.1} WU [{}]",
            rel(&rr, f),
            w.work_units,
            log(&w.cycles)
        );
    }
    // What the default local relaxation leaves, and what removes it (wave 13): global damped
    // block-Jacobi sweeps (a high-frequency remainder), a coarse-grid correction (a smooth one),
    // both, and the relaxation marking at a fraction of the tolerance.
    if let Some(l) = cycle.local_relaxation {
        let (xl, _) = local_relaxation(op, f, &x0, tolerance, l.rings, l.sweeps);
        let mut rl = vec![[0.0; 3]; n];
        op.residual(&xl, f, &mut rl);
        let el = energy(&rl);
        let tl: f64 = el.iter().sum();
        let mut sl = el.clone();
        sl.sort_by(|a, b| b.total_cmp(a));
        println!(
            "  after local {}x{}: residual {:.3e}; share on surface nodes {:.3}, top 100 {:.3}, top 1000 {:.3}, top 10000 {:.3}",
            l.rings,
            l.sweeps,
            rel(&rl, f),
            el[inner..].iter().sum::<f64>() / tl,
            sl.iter().take(100).sum::<f64>() / tl,
            sl.iter().take(1000).sum::<f64>() / tl,
            sl.iter().take(10000).sum::<f64>() / tl,
        );
        let top = h.levels.len() - 1;
        let sweep = |x: &[Rgb]| -> Vec<Rgb> {
            let mut r = vec![[0.0; 3]; n];
            op.residual(x, f, &mut r);
            (0..n)
                .map(|i| {
                    let d = op.block_solve(i, &r);
                    std::array::from_fn(|c| x[i][c] + 0.8 * d[c])
                })
                .collect()
        };
        let coarse = |x: &[Rgb], tol: f64| -> Vec<Rgb> {
            let mut r = vec![[0.0; 3]; n];
            op.residual(x, f, &mut r);
            let Some(p) = h.levels[top].prolongation.as_ref() else {
                return x.to_vec();
            };
            let mut rc = vec![[0.0; 3]; p.coarse_count()];
            p.restrict(&r, &mut rc);
            let sub = Hierarchy {
                levels: h.levels[..top].to_vec(),
                finest: h.finest.clone(),
                coarse: h.coarse,
            };
            let sub_params = MultigridParams {
                tolerance: tol,
                max_cycles: 200,
                ..cycle.clone()
            };
            let (e, _) = sub.solve(&rc, Start::Cold, &sub_params, &mut |_, _| {});
            let mut out = x.to_vec();
            p.prolong_add(&e, &mut out);
            out
        };
        let report = |name: &str, x: &[Rgb]| {
            let mut rr = vec![[0.0; 3]; n];
            op.residual(x, f, &mut rr);
            let (_, w) = h.solve(f, Start::Warm(x), &params, &mut |_, _| {});
            println!(
                "    {name}: residual {:.3e}, then {:.1} WU [{}]",
                rel(&rr, f),
                w.work_units,
                log(&w.cycles)
            );
        };
        let mut xs1 = xl.clone();
        for k in 1..=3 {
            xs1 = sweep(&xs1);
            report(&format!("+ {k} global damped block-Jacobi sweeps"), &xs1);
        }
        for tol in [1e-1, 1e-11] {
            let xc = coarse(&xl, tol);
            report(
                &format!("+ coarse correction (levels below the finest to {tol:.0e})"),
                &xc,
            );
            let xcs = sweep(&xc);
            report("  + 1 global sweep", &xcs);
            let xcs2 = sweep(&xcs);
            report("  + 2 global sweeps", &xcs2);
            let (xcl, listed) = local_relaxation(op, f, &xc, tolerance, l.rings, l.sweeps);
            report(
                &format!("  + local {}x{} again ({listed} nodes)", l.rings, l.sweeps),
                &xcl,
            );
        }
        // Sequences of local relaxations (L: the cycle's, l: 2x8) and coarse corrections (C).
        let lsmall = (2u32, 8u32);
        for seq in [
            "CL", "LCL", "LCLC", "LClC", "LCLCL", "LClCl", "LCLs", "LCsL", "LCC", "LCLCs",
        ] {
            let mut xq = x0.clone();
            let mut notes = Vec::new();
            for op_ch in seq.chars() {
                match op_ch {
                    'L' | 'l' => {
                        let (rings, sweeps) = if op_ch == 'L' {
                            (l.rings, l.sweeps)
                        } else {
                            lsmall
                        };
                        let (xn, listed) = local_relaxation(op, f, &xq, tolerance, rings, sweeps);
                        notes.push(format!("{op_ch} {listed}"));
                        xq = xn;
                    }
                    'C' => xq = coarse(&xq, 1e-1),
                    _ => xq = sweep(&xq),
                }
            }
            report(&format!("sequence {seq} ({})", notes.join(", ")), &xq);
        }
        for frac in [0.5, 0.25] {
            let (xf, listed) = local_relaxation(op, f, &x0, tolerance * frac, l.rings, l.sweeps);
            report(
                &format!("local marking at {frac} tol ({listed} nodes)"),
                &xf,
            );
        }
    }
    // The best any local fix can do: the residual on the jump nodes solved exactly (its far
    // field too), for each extrapolation order.
    for ord in 0..=2u32.min(earlier.len() as u32 - 1) {
        let xs0 = extrapolate(earlier, ord);
        let mut r0 = vec![[0.0; 3]; n];
        op.residual(&xs0, f, &mut r0);
        let (_, w) = h.solve(f, Start::Warm(&xs0), &params, &mut |_, _| {});
        println!(
            "  order {ord}: start residual {:.3e}, warm {:.1} WU [{}]",
            rel(&r0, f),
            w.work_units,
            log(&w.cycles)
        );
        let mut masked = vec![[0.0; 3]; n];
        for &i in &jumps {
            masked[i] = r0[i];
        }
        let (dx, _) = h.solve(&masked, Start::Cold, &exact_params, &mut |_, _| {});
        let xp: Vec<Rgb> = (0..n)
            .map(|i| std::array::from_fn(|c| xs0[i][c] + dx[i][c]))
            .collect();
        let mut rp = vec![[0.0; 3]; n];
        op.residual(&xp, f, &mut rp);
        let (_, w) = h.solve(f, Start::Warm(&xp), &params, &mut |_, _| {});
        println!(
            "    its residual on the jump nodes solved exactly: residual {:.3e}, then {:.1} WU [{}]",
            rel(&rp, f),
            w.work_units,
            log(&w.cycles)
        );
    }
    let (_, cold) = h.solve(f, Start::Cold, &params, &mut |_, _| {});
    let (_, warm) = h.solve(f, Start::Warm(&x0), &params, &mut |_, _| {});
    println!(
        "  f64 cycle to {tolerance:.0e}: cold {:.1} WU ({}), warm {:.1} WU ({})",
        cold.work_units,
        log(&cold.cycles),
        warm.work_units,
        log(&warm.cycles)
    );
    Ok(())
}
