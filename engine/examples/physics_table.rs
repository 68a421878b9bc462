//! Prints the physics tables of `benches/RESULTS.md`: the CPU reference solve against the closed
//! forms of DESIGN section 2, for both discretizations, under refinement.
//!
//! `cargo run --release -p translucent --example physics_table [-- slab|sphere|jacobi|all]`

use std::time::Instant;

use glam::DVec3;
use translucent::material::{fresnel, Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Scene};
use translucent::solver::analytic::Homogeneous;
use translucent::solver::{self, CpuSolveParams, Scheme};
use translucent::tet::TetMesh;
use translucent::{GraphLevel, QuadGraph};

fn bcc_slab_graph(layers: usize) -> QuadGraph {
    let tets = TetMesh::bcc_slab(50.0, 10.0, layers);
    let spacing = 10.0 * std::f64::consts::SQRT_2 / layers as f64;
    QuadGraph {
        levels: vec![GraphLevel::from_tets(tets, spacing, |c, nrm| (c, nrm))],
        ..Default::default()
    }
}

fn slab_graph(kuhn: bool, n: [usize; 3]) -> QuadGraph {
    let (min, max) = (DVec3::new(-50.0, -5.0, -50.0), DVec3::new(50.0, 5.0, 50.0));
    let tets = if kuhn {
        TetMesh::structured_box(min, max, n)
    } else {
        TetMesh::bcc_box(min, max, n)
    };
    let spacing = 10.0 / n[1] as f64;
    QuadGraph {
        levels: vec![GraphLevel::from_tets(tets, spacing, |c, nrm| (c, nrm))],
        ..Default::default()
    }
}

/// Transmittance in the centre of the far (bottom) face: mean (1 - F_dr) J+ / q_top over the bottom
/// surface nodes within 5 mm of the axis, area-weighted.
fn slab_transmittance(
    graph: &QuadGraph,
    sol: &solver::CpuSolution,
    f_dr: f64,
    q_top: [f64; 3],
) -> [f64; 3] {
    let level = graph.finest();
    let inner = level.inner_count();
    let (mut acc, mut area) = ([0.0; 3], 0.0);
    for s in 0..level.surface_count() {
        let p = level.positions[inner + s];
        if level.surface_normals[s].y < -0.5 && p.x.hypot(p.z) < 5.0_f64.max(level.spacing) {
            let a = sol.operator.areas[s];
            area += a;
            for c in 0..3 {
                acc[c] += (1.0 - f_dr) * sol.j_plus[s][c] * a / q_top[c];
            }
        }
    }
    acc.map(|v| v / area)
}

fn slab() {
    let milk = Material::preset("skimmilk").unwrap();
    let field = MaterialField::Homogeneous(milk);
    let exact: [f64; 3] =
        std::array::from_fn(|c| Homogeneous::channel(&milk, c).slab_transmittance(10.0));
    let ft = fresnel::transmittance(milk.eta, 1.0);
    let scene = Scene {
        lights: vec!["dir:0,-1,0:1,1,1".parse().unwrap()],
        environment: Environment::None,
    };
    println!("\n### Slab: skim milk, 100 x 100 x 10 mm box lit from above, transmittance at the centre\n");
    println!(
        "Exact (DESIGN section 2): R {:.4}, G {:.4}, B {:.4}\n",
        exact[0], exact[1], exact[2]
    );
    println!("| mesh | cells (x, y, z) or 2 x layers | nodes | scheme | T red | T green | T blue | max rel. error | solve s |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for mesh in 0..3 {
        for (nxz, ny) in [(20, 2), (30, 3), (40, 4), (50, 5)] {
            let kuhn = mesh == 2;
            let graph = if mesh == 0 {
                bcc_slab_graph(ny * 2)
            } else {
                slab_graph(kuhn, [nxz, ny, nxz])
            };
            for scheme in [Scheme::Fv, Scheme::Paper] {
                let t0 = Instant::now();
                let params = CpuSolveParams {
                    scheme,
                    iterations: vec![0],
                    ..Default::default()
                };
                let sol = solver::solve(&graph, &field, &scene, None, &params).unwrap();
                let t = slab_transmittance(&graph, &sol, milk.f_dr(), [ft; 3]);
                let err = (0..3)
                    .map(|c| (t[c] / exact[c] - 1.0).abs())
                    .fold(0.0, f64::max);
                println!(
                    "| {} | {nxz}, {ny}, {nxz} | {} | {:?} | {:.4} | {:.4} | {:.4} | {:.2}% | {:.1} |",
                    ["BCC {011} slab", "BCC box", "Kuhn box"][mesh],
                    graph.finest().node_count(),
                    scheme,
                    t[0],
                    t[1],
                    t[2],
                    100.0 * err,
                    t0.elapsed().as_secs_f64()
                );
            }
        }
    }
}

fn sphere_graph(resolution: u32, k: f64, levels: u32) -> QuadGraph {
    let ball = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution,
        k,
        levels,
        ..Default::default()
    };
    QuadGraph::bake(&ball.triangulate(64), &ball, &params, &mut |_| {})
        .unwrap()
        .0
}

fn sphere() {
    println!(
        "\n### Sphere: R = 10 mm, constant environment, albedo = exitance / transmitted input\n"
    );
    println!("Relative error per channel (R, G, B) against the closed form; bake `BakeParams {{ resolution, levels: 1, ..Default::default() }}` (K = {}; 48 is the default resolution).\n", BakeParams::default().k);
    println!("| resolution | nodes | material | scheme | albedo R, G, B | exact R, G, B | error R, G, B | solve s |");
    println!("|---|---|---|---|---|---|---|---|");
    let scene = Scene {
        lights: vec![],
        environment: Environment::Constant([1.0; 3]),
    };
    for resolution in [12, 24, 32, 48, 64] {
        let graph = sphere_graph(resolution, BakeParams::default().k, 1);
        for name in ["marble", "skin1"] {
            let m = Material::preset(name).unwrap();
            let field = MaterialField::Homogeneous(m);
            let exact: [f64; 3] =
                std::array::from_fn(|c| Homogeneous::channel(&m, c).sphere_albedo(10.0));
            for scheme in [Scheme::Fv, Scheme::Paper] {
                let t0 = Instant::now();
                let params = CpuSolveParams {
                    scheme,
                    iterations: vec![0],
                    ..Default::default()
                };
                let sol = solver::solve(&graph, &field, &scene, None, &params).unwrap();
                let e = sol.energy;
                let a: [f64; 3] = std::array::from_fn(|c| e.exitance[c] / e.transmitted_input[c]);
                let err: [f64; 3] = std::array::from_fn(|c| 100.0 * (a[c] / exact[c] - 1.0));
                println!(
                    "| {resolution} | {} | {name} | {scheme:?} | {:.4}, {:.4}, {:.4} | {:.4}, {:.4}, {:.4} | {:+.3}%, {:+.3}%, {:+.3}% | {:.1} |",
                    graph.finest().node_count(),
                    a[0], a[1], a[2], exact[0], exact[1], exact[2], err[0], err[1], err[2],
                    t0.elapsed().as_secs_f64()
                );
            }
        }
    }
}

/// Jacobi iterations to a tolerance with and without the multi-level initialisation.
fn jacobi() {
    println!(
        "\n### Jacobi: single level against the multi-level initialisation (paper section 4.3)\n"
    );
    println!("Sphere R = 10 mm, marble, directional light `dir:0,-1,0:1,1,1`; Jacobi stops at an estimated relative error of 1e-4; error = max |phi - phi_exact| / max |phi_exact| on the finest level.\n");
    println!("| resolution | levels | nodes per level | iterations per level | error vs exact | Jacobi s |");
    println!("|---|---|---|---|---|---|");
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let scene = Scene {
        lights: vec!["dir:0,-1,0:1,1,1".parse().unwrap()],
        environment: Environment::None,
    };
    for resolution in [24, 32] {
        let full = sphere_graph(resolution, BakeParams::default().k, 3);
        let exact = solver::solve(
            &full,
            &field,
            &scene,
            None,
            &CpuSolveParams {
                iterations: vec![0],
                ..Default::default()
            },
        )
        .unwrap();
        let scale = exact
            .phi
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        for levels in [1, 2, 3] {
            let graph = QuadGraph {
                levels: full.levels[3 - levels..].to_vec(),
                ..Default::default()
            };
            let mut graph = graph;
            graph.levels[0].from_coarser = None;
            let params = CpuSolveParams {
                iterations: vec![200_000],
                tolerance: 1e-4,
                exact: false,
                ..Default::default()
            };
            let t0 = Instant::now();
            let sol = solver::solve(&graph, &field, &scene, None, &params).unwrap();
            let secs = t0.elapsed().as_secs_f64();
            let err = sol
                .phi
                .iter()
                .flatten()
                .zip(exact.phi.iter().flatten())
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
                / scale;
            let nodes: Vec<usize> = graph.levels.iter().map(|l| l.node_count()).collect();
            let its: Vec<usize> = sol.levels.iter().map(|l| l.jacobi_iterations).collect();
            println!("| {resolution} | {levels} | {nodes:?} | {its:?} | {err:.1e} | {secs:.1} |");
        }
    }
}

/// Reflectance at the centre of the lit face of a thick {011} BCC block against the semi-infinite
/// albedo: isolates the boundary layer of strongly absorbing channels (skin1 blue: 1/s = 0.68 mm).
fn semi_infinite() {
    println!("\n### Semi-infinite medium: skin1, reflectance at the centre of the face lit from above (block 6 x 4 x 6 mm; red, whose diffusion length is 3.7 mm, sees the block's sides: only green and blue are semi-infinite here)\n");
    println!("| layers | tetrahedron layer (mm) | nodes | scheme | R red | R green | R blue | exact R, G, B | max rel. error (G, B) |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let m = Material::preset("skin1").unwrap();
    let field = MaterialField::Homogeneous(m);
    let exact: [f64; 3] =
        std::array::from_fn(|c| Homogeneous::channel(&m, c).semi_infinite_albedo());
    let scene = Scene {
        lights: vec!["dir:0,-1,0:1,1,1".parse().unwrap()],
        environment: Environment::None,
    };
    for layers in [6, 10, 16, 24] {
        let thickness = 4.0;
        let tets = TetMesh::bcc_slab(3.0, thickness, layers);
        let spacing = thickness * std::f64::consts::SQRT_2 / layers as f64;
        let graph = QuadGraph {
            levels: vec![GraphLevel::from_tets(tets, spacing, |c, n| (c, n))],
            ..Default::default()
        };
        for scheme in [Scheme::Fv, Scheme::Paper] {
            let params = CpuSolveParams {
                scheme,
                iterations: vec![0],
                ..Default::default()
            };
            let sol = solver::solve(&graph, &field, &scene, None, &params).unwrap();
            let level = graph.finest();
            let inner = level.inner_count();
            let (mut acc, mut area) = ([0.0; 3], 0.0);
            for s in 0..level.surface_count() {
                let p = level.positions[inner + s];
                if level.surface_normals[s].y > 0.999 && p.x.hypot(p.z) < 1.0 {
                    let a = sol.operator.areas[s];
                    area += a;
                    for (c, r) in acc.iter_mut().enumerate() {
                        *r += (1.0 - m.f_dr()) * sol.j_plus[s][c] * a / sol.q[s][c];
                    }
                }
            }
            let r = acc.map(|v| v / area);
            let err = (1..3)
                .map(|c| (r[c] / exact[c] - 1.0).abs())
                .fold(0.0, f64::max);
            println!(
                "| {layers} | {:.3} | {} | {scheme:?} | {:.4} | {:.4} | {:.4} | {:.4}, {:.4}, {:.4} | {:.2}% |",
                thickness / layers as f64, level.node_count(), r[0], r[1], r[2], exact[0], exact[1], exact[2], 100.0 * err
            );
        }
    }
}

fn main() {
    let what = std::env::args().nth(1).unwrap_or_else(|| "all".into());
    if what == "slab" || what == "all" {
        slab();
    }
    if what == "semi" || what == "all" {
        semi_infinite();
    }
    if what == "sphere" || what == "all" {
        sphere();
    }
    if what == "jacobi" || what == "all" {
        jacobi();
    }
}
