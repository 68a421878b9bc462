//! Multigrid (CPU f64 prototype, `solver::multigrid`) measurements for `benches/RESULTS.md`,
//! section "Multigrid (CPU prototype)": cycles, work units (node updates / finest nodes) and
//! convergence factors to relative residuals 1e-2, 1e-3, 1e-4 for smoothers, sweep counts and
//! coarse operators; the J+ error against the exact solution at each; warm start against cold
//! full multigrid at 3 degrees of light rotation per frame; the paper's cascade for comparison.
//!
//! ```text
//! cargo run --release -p translucent-benches --bin multigrid -- [--only SECTION] [--scene NAME]
//! ```
//! SECTION: `schedules`, `omega`, `warm`, `cascade`, `stopping`; NAME: `default`, `spot`,
//! `contrast`, `absorption0`, `size1mm`, `size10m` (several `--scene` allowed; default: all).
//! Prints markdown tables. Work units and cycles are deterministic; seconds are wall-clock.

use std::time::Instant;

use glam::{DQuat, DVec3};
use translucent::material::{Coefficients, Material, MaterialField, Procedural};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::solver::krylov;
use translucent::solver::multigrid::{
    CoarseOperator, Hierarchy, Interpolation, MultigridParams, MultigridReport, Smoother, Start,
};
use translucent::solver::operator::LevelOperator;
use translucent::solver::{self, CpuSolveParams, Schedule, Scheme};
use translucent::QuadGraph;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// Residual targets of the tables.
const TARGETS: [f64; 3] = [1e-2, 1e-3, 1e-4];
/// The reference solution's relative residual (far below every target).
const EXACT_RESIDUAL: f64 = 1e-11;

struct Scenario {
    name: &'static str,
    what: String,
    graph: QuadGraph,
    field: MaterialField,
    scene: Scene,
    solid: Box<dyn Solid>,
}

fn default_lights() -> Vec<Light> {
    vec![
        "dir:0.2,-0.35,1:5,5,5".parse().expect("light"),
        "dir:-0.6,-0.7,-0.4:0.6,0.6,0.6".parse().expect("light"),
    ]
}

fn bake(surface: &TriMesh, solid: &dyn Solid, resolution: u32, levels: u32) -> Result<QuadGraph> {
    let params = BakeParams {
        resolution,
        levels,
        ..Default::default()
    };
    Ok(QuadGraph::bake(surface, solid, &params, &mut |_| {})?.0)
}

fn shape_scenario(
    name: &'static str,
    what: String,
    shape: Shape,
    resolution: u32,
    field: MaterialField,
    scene: Scene,
) -> Result<Scenario> {
    let surface = shape.triangulate(96);
    let graph = bake(&surface, &shape, resolution, 3)?;
    Ok(Scenario {
        name,
        what,
        graph,
        field,
        scene,
        solid: Box::new(shape),
    })
}

fn torus(size: f64) -> Shape {
    Shape::Torus {
        major: 0.35 * size,
        minor: 0.15 * size,
    }
}

fn scenario(name: &str) -> Result<Scenario> {
    let default_scene = Scene {
        lights: default_lights(),
        environment: Environment::None,
    };
    let skim = || Material::preset("skimmilk").map(MaterialField::Homogeneous);
    Ok(match name {
        "default" => shape_scenario(
            "default",
            "torus 50 mm, skim milk, default lights, resolution 48, 3 levels".into(),
            torus(50.0),
            48,
            skim()?,
            default_scene,
        )?,
        "spot" => {
            let dir = std::env::var_os("TRANSLUCENT_MESH_DIR")
                .map(std::path::PathBuf::from)
                .unwrap_or_else(|| "../shared/meshes".into());
            let (solid, _, _) =
                MeshSolid::load(dir.join("spot.obj"), 50.0, &ValidateOptions::default())?;
            let surface = solid.mesh().clone();
            let graph = bake(&surface, &solid, 48, 3)?;
            Scenario {
                name: "spot",
                what: "spot 50 mm, marble, default lights, resolution 48, 3 levels".into(),
                graph,
                field: MaterialField::Homogeneous(Material::preset("marble")?),
                scene: default_scene,
                solid: Box::new(solid),
            }
        }
        "contrast" => {
            // kappa 1e4 apart across a plane through the torus, no absorption anywhere.
            let c = |s: f64| Coefficients::new([s; 3], [0.0; 3]);
            let field = MaterialField::procedural(
                Procedural::Split {
                    normal: DVec3::new(1.0, 0.3, 0.1).normalize(),
                    offset: 0.0,
                    below: c(0.1)?,
                    above: c(1000.0)?,
                },
                1.3,
            )?;
            shape_scenario(
                "contrast",
                "torus 50 mm, split sigma_s' 0.1 / 1000 (kappa 1e4 apart), sigma_a 0, default lights, resolution 48".into(),
                torus(50.0),
                48,
                field,
                default_scene,
            )?
        }
        "absorption0" => shape_scenario(
            "absorption0",
            "torus 50 mm, sigma_s' 1, sigma_a 0, default lights, resolution 48".into(),
            torus(50.0),
            48,
            MaterialField::Homogeneous(Material::new([1.0; 3], [0.0; 3], 1.3)?),
            default_scene,
        )?,
        "size1mm" => shape_scenario(
            "size1mm",
            "torus 1 mm, skim milk, default lights, resolution 48".into(),
            torus(1.0),
            48,
            skim()?,
            default_scene,
        )?,
        "size10m" => shape_scenario(
            "size10m",
            "torus 10 m, skim milk, default lights, resolution 48".into(),
            torus(1e4),
            48,
            skim()?,
            default_scene,
        )?,
        other => {
            // SHAPE:SIZE_MM:MATERIAL:RESOLUTION:K:LEVELS (experiments).
            let f: Vec<&str> = other.split(':').collect();
            if f.len() != 6 {
                return Err(format!("unknown scene {other}").into());
            }
            let size: f64 = f[1].parse()?;
            let shape = match f[0] {
                "sphere" => Shape::Sphere { radius: 0.5 * size },
                "torus" => torus(size),
                "box" => Shape::Box {
                    half_extents: DVec3::new(0.5, 0.3, 0.4) * size,
                },
                s => return Err(format!("shape {s}").into()),
            };
            let surface = shape.triangulate(96);
            let params = BakeParams {
                resolution: f[3].parse()?,
                k: f[4].parse()?,
                levels: f[5].parse()?,
                ..Default::default()
            };
            let graph = QuadGraph::bake(&surface, &shape, &params, &mut |_| {})?.0;
            Scenario {
                name: "custom",
                what: other.to_string(),
                graph,
                field: MaterialField::Homogeneous(Material::preset(f[2])?),
                scene: default_scene,
                solid: Box::new(shape),
            }
        }
    })
}

/// The finest level's scaled right-hand side and its exact (to [`EXACT_RESIDUAL`]) solution.
struct Problem {
    f: Vec<[f64; 3]>,
    q: Vec<[f64; 3]>,
    exact_j: Vec<[f64; 3]>,
}

fn j_plus(op: &LevelOperator, phi: &[[f64; 3]], q: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let inner = op.inner_count;
    q.iter()
        .enumerate()
        .map(|(s, qs)| {
            std::array::from_fn(|c| {
                (1.0 + 1.0 / op.a) * phi[inner + s][c] / 4.0 - qs[c] / (1.0 + op.f_dr)
            })
        })
        .collect()
}

/// Relative RMS over all channels, sqrt(sum (a - b)^2 / sum b^2).
fn rel_rms(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            num += (x[c] - y[c]).powi(2);
            den += y[c] * y[c];
        }
    }
    (num / den.max(f64::MIN_POSITIVE)).sqrt()
}

fn problem(s: &Scenario, mg: &Hierarchy, scene: &Scene) -> Problem {
    // The reference is PCG on the finest level (solver::krylov), independent of the multigrid:
    // a multigrid configuration that diverges must not take its own reference down with it.
    let level = s.graph.finest();
    let q = scene.surface_irradiance(level, s.field.eta(), Some(s.solid.as_ref()));
    let f = mg.scaled_rhs(&q);
    let b = mg.finest.rhs(&q);
    let mut phi = vec![[0.0; 3]; level.node_count()];
    let report = krylov::solve(&mg.finest, &b, &mut phi, EXACT_RESIDUAL, 200_000);
    assert!(
        report.converged,
        "{}: the reference solve reached only {:?}",
        s.name, report.residual
    );
    let exact_j = j_plus(&mg.finest, &phi, &q);
    Problem { f, q, exact_j }
}

/// Per target: (cycles, work units, J+ error) when first reached.
type Reached = [Option<(usize, f64, f64)>; 3];

fn run(
    mg: &Hierarchy,
    p: &Problem,
    params: &MultigridParams,
    start: Start,
) -> (Reached, MultigridReport, Vec<[f64; 3]>) {
    let mut reached: Reached = [None; 3];
    let mut cycles = 0;
    let mut work = 0.0;
    let (phi, report) = mg.solve(&p.f, start, params, &mut |x, c| {
        cycles += 1;
        work += c.work_units;
        for (t, r) in TARGETS.iter().zip(reached.iter_mut()) {
            if r.is_none() && c.residual < *t {
                let err = rel_rms(&j_plus(&mg.finest, x, &p.q), &p.exact_j);
                *r = Some((cycles, work, err));
            }
        }
    });
    (reached, report, phi)
}

fn fmt_reached(r: &Option<(usize, f64, f64)>) -> String {
    match r {
        Some((c, w, e)) => format!("{c} / {w:.1} / {e:.1e}"),
        None => "-".into(),
    }
}

fn smoother_name(s: Smoother) -> String {
    match s {
        Smoother::Jacobi { omega } => format!("Jacobi omega {omega}"),
        Smoother::Chebyshev { lower } => format!("Chebyshev [{lower} lmax, lmax]"),
    }
}

fn describe(s: &Scenario) {
    let nodes: Vec<usize> = s.graph.levels.iter().map(|l| l.node_count()).collect();
    println!("\n#### {}: {}\nnodes per level {nodes:?}\n", s.name, s.what);
}

/// A configuration written `key=value,...` (keys: interp shepard|linear|mixed, coarse re|gal,
/// smoother jac:OMEGA|cheb:LOWER, nu PRE/POST, blocks 0|1, krylov 0|1, sp S, ctol T, cnu N
/// middle-level sweeps, fmg N V-cycles per level of the cold start, gpu=1 the GPU defaults first).
fn parse_config(text: &str) -> Result<MultigridParams> {
    let mut p = MultigridParams::default();
    for item in text.split(',').filter(|i| !i.is_empty()) {
        let (key, value) = item
            .split_once('=')
            .ok_or_else(|| format!("config item {item}"))?;
        match key {
            "interp" => {
                p.interpolation = match value {
                    "shepard" => Interpolation::Shepard,
                    "linear" => Interpolation::Linear,
                    "mixed" => Interpolation::Mixed,
                    v => return Err(format!("interp {v}").into()),
                }
            }
            "coarse" => {
                p.coarse = match value {
                    "re" => CoarseOperator::Rediscretized,
                    "gal" => CoarseOperator::Galerkin,
                    v => return Err(format!("coarse {v}").into()),
                }
            }
            "smoother" => {
                let (kind, x) = value.split_once(':').ok_or("smoother KIND:X")?;
                let x: f64 = x.parse()?;
                p.smoother = match kind {
                    "jac" => Smoother::Jacobi { omega: x },
                    "cheb" => Smoother::Chebyshev { lower: x },
                    v => return Err(format!("smoother {v}").into()),
                };
            }
            "nu" => {
                let (a, b) = value.split_once('/').ok_or("nu PRE/POST")?;
                p.pre_sweeps = a.parse()?;
                p.post_sweeps = b.parse()?;
            }
            "blocks" => p.surface_blocks = value == "1",
            "krylov" => p.krylov = value == "1",
            "sp" => p.smoothed_prolongation = Some(value.parse()?),
            "ctol" => p.coarse_tolerance = value.parse()?,
            "cnu" => p.coarse_sweeps = Some(value.parse()?),
            "fmg" => p.fmg_cycles = value.parse()?,
            "gpu" => p = MultigridParams::gpu(),
            k => return Err(format!("config key {k}").into()),
        }
    }
    Ok(p)
}

fn config_name(p: &MultigridParams) -> String {
    format!(
        "{:?}, {:?}, {}, {}/{}{}{}{}",
        p.coarse,
        p.interpolation,
        smoother_name(p.smoother),
        p.pre_sweeps,
        p.post_sweeps,
        if p.surface_blocks { ", blocks" } else { "" },
        if p.krylov { ", CG" } else { "" },
        p.smoothed_prolongation
            .map_or(String::new(), |s| format!(", smoothed P {s}")),
    )
}

fn schedules(s: &Scenario, configs: &[MultigridParams]) -> Result<()> {
    describe(s);
    println!("| configuration | 1e-2: cycles / WU / J+ err | 1e-3 | 1e-4 | mean factor | last factor | coarse stencil | matvec units to 1e-4 | setup s | solve s |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut cache: Vec<(String, Hierarchy)> = Vec::new();
    let mut reference: Option<Problem> = None;
    for params in configs {
        let params = MultigridParams {
            tolerance: 1e-4,
            max_cycles: 200,
            ..params.clone()
        };
        let key = format!(
            "{:?} {:?} {} {}",
            params.coarse,
            params.interpolation,
            params.surface_blocks,
            matches!(params.smoother, Smoother::Chebyshev { .. })
                || params.smoothed_prolongation.is_some()
        );
        let t = Instant::now();
        let index = match cache.iter().position(|(k, _)| *k == key) {
            Some(i) => i,
            None => {
                let mg = Hierarchy::build(&s.graph, &s.field, Scheme::Fv, &params)?;
                cache.push((key, mg));
                cache.len() - 1
            }
        };
        let setup = t.elapsed().as_secs_f64();
        let mg = &cache[index].1;
        let p = match &reference {
            Some(p) => p,
            None => reference.insert(problem(s, mg, &s.scene)),
        };
        let t = Instant::now();
        let (reached, report, _) = run(mg, p, &params, Start::Cold);
        let solve_s = t.elapsed().as_secs_f64();
        let stencil = mg.levels[..mg.levels.len() - 1]
            .iter()
            .map(|l| format!("{:.1}", l.operator.mean_row_entries()))
            .collect::<Vec<_>>()
            .join(", ");
        println!(
            "| {} | {} | {} | {} | {} | {} | {stencil} | {:.1} | {setup:.1} | {solve_s:.1} |",
            config_name(&params),
            fmt_reached(&reached[0]),
            fmt_reached(&reached[1]),
            fmt_reached(&reached[2]),
            report.mean_factor.map_or("-".into(), |f| format!("{f:.3}")),
            report
                .cycles
                .last()
                .map_or("-".into(), |c| format!("{:.3}", c.factor)),
            report.matvec_units,
        );
    }
    Ok(())
}

fn warm(s: &Scenario, params: &MultigridParams, frames: usize, tolerances: &[f64]) -> Result<()> {
    describe(s);
    let mg = Hierarchy::build(&s.graph, &s.field, Scheme::Fv, params)?;
    println!("| tolerance | frame | warm: cycles / WU / J+ err | cold FMG: cycles / WU / J+ err | cold / warm WU |");
    println!("|---|---|---|---|---|");
    for &tol in tolerances {
        let params = MultigridParams {
            tolerance: tol,
            ..params.clone()
        };
        // Frame 0 is the solve a host had before the light moved.
        let p0 = problem(s, &mg, &s.scene);
        let (_, _, mut previous) = run(&mg, &p0, &params, Start::Cold);
        for frame in 1..=frames {
            let turn = DQuat::from_rotation_y((3.0 * frame as f64).to_radians());
            let scene = Scene {
                lights: s.scene.lights.iter().map(|l| l.rotated(turn)).collect(),
                environment: s.scene.environment,
            };
            let p = problem(s, &mg, &scene);
            let (_, warm_report, phi) = run(&mg, &p, &params, Start::Warm(&previous));
            let warm_err = rel_rms(&j_plus(&mg.finest, &phi, &p.q), &p.exact_j);
            let (_, cold_report, cold_phi) = run(&mg, &p, &params, Start::Cold);
            let cold_err = rel_rms(&j_plus(&mg.finest, &cold_phi, &p.q), &p.exact_j);
            println!(
                "| {tol:.0e} | {frame} | {} / {:.1} / {warm_err:.1e} | {} / {:.1} / {cold_err:.1e} | {:.1} |",
                warm_report.cycles.len(),
                warm_report.work_units,
                cold_report.cycles.len(),
                cold_report.work_units,
                cold_report.work_units / warm_report.work_units.max(1e-9),
            );
            previous = phi;
        }
    }
    Ok(())
}

fn cascade(s: &Scenario) -> Result<()> {
    describe(s);
    let mg = Hierarchy::build(&s.graph, &s.field, Scheme::Fv, &MultigridParams::default())?;
    let p = problem(s, &mg, &s.scene);
    let finest = s.graph.finest().node_count() as f64;
    println!("| cascade tolerance (estimated error) | iterations per level | work units | relative residual | J+ err |");
    println!("|---|---|---|---|---|");
    for tol in TARGETS {
        let sol = solver::solve(
            &s.graph,
            &s.field,
            &s.scene,
            Some(s.solid.as_ref()),
            &CpuSolveParams {
                iterations: vec![100_000],
                tolerance: tol,
                exact: false,
                schedule: Schedule::Cascade,
                ..Default::default()
            },
        )?;
        let iterations: Vec<usize> = sol.levels.iter().map(|l| l.jacobi_iterations).collect();
        let work: f64 = sol
            .levels
            .iter()
            .zip(&s.graph.levels)
            .map(|(r, l)| r.jacobi_iterations as f64 * l.node_count() as f64)
            .sum::<f64>()
            / finest;
        let residual = sol.residual.iter().copied().fold(0.0, f64::max);
        let err = rel_rms(&sol.j_plus, &p.exact_j);
        println!("| {tol:.0e} | {iterations:?} | {work:.0} | {residual:.1e} | {err:.1e} |");
    }
    Ok(())
}

fn diag(s: &Scenario) -> Result<()> {
    describe(s);
    for (interpolation, surface_blocks) in [
        (Interpolation::Shepard, true),
        (Interpolation::Linear, true),
        (Interpolation::Shepard, false),
    ] {
        for coarse in [CoarseOperator::Rediscretized, CoarseOperator::Galerkin] {
            // The V-cycle's slowest error mode: cycles on K e = 0 from a random start.
            let params = MultigridParams {
                interpolation,
                coarse,
                surface_blocks,
                smoother: Smoother::Chebyshev {
                    lower: std::env::var("MG_LOWER")
                        .ok()
                        .and_then(|v| v.parse().ok())
                        .unwrap_or(0.25),
                },
                pre_sweeps: std::env::var("MG_NU")
                    .ok()
                    .and_then(|v| v.parse().ok())
                    .unwrap_or(2),
                post_sweeps: std::env::var("MG_NU")
                    .ok()
                    .and_then(|v| v.parse().ok())
                    .unwrap_or(2),
                smoothed_prolongation: std::env::var("MG_SP").ok().and_then(|v| v.parse().ok()),
                coarse_tolerance: 1e-10,
                max_cycles: 30,
                tolerance: 0.0,
                ..MultigridParams::default()
            };
            let mg = Hierarchy::build(&s.graph, &s.field, Scheme::Fv, &params)?;
            let k = &mg.levels.last().expect("levels").operator;
            let n = k.node_count();
            let mut e: Vec<[f64; 3]> = (0..n)
                .map(|i| {
                    let h = ((i as u64 * 2654435761) % 1000) as f64 / 1000.0 - 0.5;
                    [h; 3]
                })
                .collect();
            let zero = vec![[0.0; 3]; n];
            let energy = |e: &[[f64; 3]]| -> f64 {
                let mut ke = vec![[0.0; 3]; n];
                k.apply(e, &mut ke);
                e.iter().zip(&ke).map(|(a, b)| a[0] * b[0]).sum::<f64>()
            };
            let mut factors = Vec::new();
            for _ in 0..25 {
                let before = energy(&e).sqrt();
                let (next, _) = mg.solve(
                    &zero,
                    Start::Warm(&e),
                    &MultigridParams {
                        max_cycles: 1,
                        tolerance: 0.0,
                        ..params.clone()
                    },
                    &mut |_, _| {},
                );
                e = next;
                factors.push(energy(&e).sqrt() / before);
            }
            let f: Vec<String> = factors.iter().map(|x| format!("{x:.3}")).collect();
            println!(
                "{interpolation:?} blocks {surface_blocks} {coarse:?} energy-norm factors: {}",
                f.join(" ")
            );
            let inner = mg.finest.inner_count;
            let d: f64 = e.iter().zip(&k.diag).map(|(a, m)| a[0] * a[0] * m[0]).sum();
            println!("  Rayleigh quotient e'Ke / e'De = {:.4}", energy(&e) / d);
            let (ei, es) = (
                e[..inner].iter().map(|v| v[0] * v[0]).sum::<f64>(),
                e[inner..].iter().map(|v| v[0] * v[0]).sum::<f64>(),
            );
            println!(
                "  error^2 share: inner {:.3}, surface {:.3}",
                ei / (ei + es),
                es / (ei + es)
            );
            if let Some(h) = std::env::var("MG_BOX")
                .ok()
                .and_then(|v| v.parse::<f64>().ok())
            {
                // Error energy by depth below the box's surface, in fine spacings.
                let half = DVec3::new(0.5, 0.3, 0.4) * h;
                let sp = s.graph.finest().spacing;
                let mut bins = vec![(0.0f64, 0usize, 0.0f64); 12];
                for (i, v) in e.iter().enumerate() {
                    let p = s.graph.finest().positions[i];
                    let d = (half - p.abs()).min_element().max(0.0) / sp;
                    let b = ((d * 2.0) as usize).min(11);
                    bins[b].0 += v[0] * v[0];
                    bins[b].1 += 1;
                    bins[b].2 = bins[b].2.max(v[0].abs());
                }
                let total: f64 = bins.iter().map(|b| b.0).sum();
                for (b, (en, n, mx)) in bins.iter().enumerate() {
                    println!(
                        "  depth {:.1}-{:.1} h: share {:.3} nodes {n} rms {:.2e} max {mx:.2e}",
                        b as f64 / 2.0,
                        (b + 1) as f64 / 2.0,
                        en / total,
                        (en / (*n).max(1) as f64).sqrt()
                    );
                }
            }
            let mut worst: Vec<(f64, usize)> =
                e.iter().enumerate().map(|(i, v)| (v[0].abs(), i)).collect();
            worst.sort_by(|a, b| b.0.total_cmp(&a.0));
            let level = s.graph.finest();
            for &(v, i) in worst.iter().take(6) {
                let kind = if i < inner { "inner" } else { "surface" };
                let nb: Vec<String> = (k.row_start[i]..k.row_start[i + 1])
                    .map(|x| format!("{}:{:.2}", k.cols[x], -k.values[x][0] / k.diag[i][0]))
                    .collect();
                println!(
                    "  node {i} {kind} at {:.2?}: e {v:.2e}, weights {}",
                    level.positions[i],
                    nb.join(" ")
                );
            }
        }
    }
    if std::env::var_os("MG_DIAG_ONLY").is_some() {
        return Ok(());
    }
    for interpolation in [Interpolation::Shepard, Interpolation::Linear] {
        let params = MultigridParams {
            interpolation,
            coarse_tolerance: 1e-10,
            max_cycles: 12,
            tolerance: 0.0,
            ..MultigridParams::default()
        };
        let mg = Hierarchy::build(&s.graph, &s.field, Scheme::Fv, &params)?;
        for l in &mg.levels {
            println!("lambda_max {:?}", l.lambda_max);
        }
        let p = problem(s, &mg, &s.scene);
        let (_, report, x) = run(&mg, &p, &params, Start::Cold);
        let f: Vec<String> = report
            .cycles
            .iter()
            .map(|c| format!("{:.3}", c.factor))
            .collect();
        println!("{interpolation:?}: factors {}", f.join(" "));
        let k = &mg.levels.last().expect("levels").operator;
        let mut r = vec![[0.0; 3]; x.len()];
        k.residual(&x, &p.f, &mut r);
        let inner = mg.finest.inner_count;
        let e = |range: std::ops::Range<usize>| -> f64 {
            r[range]
                .iter()
                .map(|v| v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
                .sum()
        };
        let (ri, rs) = (e(0..inner), e(inner..x.len()));
        println!(
            "residual^2 share: inner {:.3}, surface {:.3}",
            ri / (ri + rs),
            rs / (ri + rs)
        );
        for &i in &[176851usize, 101472, 108821] {
            let links = s.graph.finest().from_coarser.as_ref().expect("links");
            let coarse = &s.graph.levels[s.graph.levels.len() - 2];
            let l: Vec<String> = links.links[i]
                .iter()
                .zip(&links.weights[i])
                .filter(|(c, _)| **c != u32::MAX)
                .map(|(&c, w)| format!("{c}:{:.1?}@{w:.2}", coarse.positions[c as usize]))
                .collect();
            println!(
                "node {i} at {:.1?} links {}",
                s.graph.finest().positions[i],
                l.join(" ")
            );
        }
        // Where the inner residual lives: by distance of the node to the nearest surface node.
        let level = s.graph.finest();
        let mut worst: Vec<(f64, usize)> = (0..x.len())
            .map(|i| (r[i][0].abs() / k.diag[i][0], i))
            .collect();
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        for &(v, i) in worst.iter().take(8) {
            let kind = if i < inner { "inner" } else { "surface" };
            let nb: Vec<String> = (k.row_start[i]..k.row_start[i + 1])
                .map(|e| format!("{:.2}", -k.values[e][0] / k.diag[i][0]))
                .collect();
            println!(
                "  node {i} {kind} at {:.1?}: D^-1 r {v:.2e}, weights {}",
                level.positions[i],
                nb.join(" ")
            );
        }
    }
    Ok(())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut only: Vec<String> = Vec::new();
    let mut scenes: Vec<String> = Vec::new();
    let mut configs: Vec<String> = Vec::new();
    let mut i = 0;
    while i < args.len() {
        match (args[i].as_str(), args.get(i + 1)) {
            ("--only", Some(v)) => only.push(v.clone()),
            ("--scene", Some(v)) => scenes.push(v.clone()),
            ("--config", Some(v)) => configs.extend(v.split(';').map(String::from)),
            (other, _) => return Err(format!("unknown argument {other}").into()),
        }
        i += 2;
    }
    let want = |s: &str| only.is_empty() || only.iter().any(|o| o == s);
    if scenes.is_empty() {
        scenes = [
            "default",
            "spot",
            "contrast",
            "absorption0",
            "size1mm",
            "size10m",
        ]
        .map(String::from)
        .to_vec();
    }
    if configs.is_empty() {
        configs.push(String::new());
    }
    for name in &scenes {
        let s = scenario(name)?;
        if want("schedules") {
            let configs = configs
                .iter()
                .map(|c| parse_config(c))
                .collect::<Result<Vec<_>>>()?;
            schedules(&s, &configs)?;
        }
        if want("diag") {
            diag(&s)?;
        }
        if want("warm") {
            warm(&s, &MultigridParams::default(), 3, &[1e-3, 1e-4])?;
        }
        if want("cascade") {
            cascade(&s)?;
        }
    }
    Ok(())
}
