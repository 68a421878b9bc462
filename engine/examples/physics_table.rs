//! Prints the physics tables of `benches/RESULTS.md`: the CPU reference solve against the closed
//! forms of DESIGN section 2, for both discretizations, under refinement.
//!
//! `cargo run --release -p translucent --example physics_table [-- slab|sphere|jacobi|all]`

use std::time::Instant;

use glam::DVec3;
use translucent::material::{fresnel, Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::solver::analytic::Homogeneous;
use translucent::solver::{self, CpuSolveParams, Environment, Scene, Scheme};
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
    println!("| mesh | cells (x, y, z) | nodes | scheme | T red | T green | T blue | max rel. error | solve s |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for mesh in 0..3 {
        for (nxz, ny) in [(20, 2), (30, 3), (40, 4), (50, 5), (60, 6)] {
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
    println!("| material | resolution | K | nodes | scheme | albedo R, G, B | exact R, G, B | max rel. error | solve s |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let scene = Scene {
        lights: vec![],
        environment: Environment::Constant([1.0; 3]),
    };
    for name in ["marble", "skin1"] {
        let m = Material::preset(name).unwrap();
        let field = MaterialField::Homogeneous(m);
        let exact: [f64; 3] =
            std::array::from_fn(|c| Homogeneous::channel(&m, c).sphere_albedo(10.0));
        for (resolution, k) in [(12, 0.5), (24, 0.5), (48, 0.5), (48, 0.0)] {
            let graph = sphere_graph(resolution, k, 1);
            for scheme in [Scheme::Fv, Scheme::Paper] {
                let t0 = Instant::now();
                let params = CpuSolveParams {
                    scheme,
                    iterations: vec![0],
                    ..Default::default()
                };
                let sol = solver::solve(&graph, &field, &scene, None, &params).unwrap();
                let e = sol.energy;
                let albedo: [f64; 3] =
                    std::array::from_fn(|c| e.exitance[c] / e.transmitted_input[c]);
                let err = (0..3)
                    .map(|c| (albedo[c] / exact[c] - 1.0).abs())
                    .fold(0.0, f64::max);
                println!(
                    "| {name} | {resolution} | {k} | {} | {scheme:?} | {:.4}, {:.4}, {:.4} | {:.4}, {:.4}, {:.4} | {:.2}% | {:.1} |",
                    graph.finest().node_count(),
                    albedo[0], albedo[1], albedo[2], exact[0], exact[1], exact[2],
                    100.0 * err,
                    t0.elapsed().as_secs_f64()
                );
            }
        }
    }
}

fn main() {
    let what = std::env::args().nth(1).unwrap_or_else(|| "all".into());
    if what == "slab" || what == "all" {
        slab();
    }
    if what == "sphere" || what == "all" {
        sphere();
    }
}
