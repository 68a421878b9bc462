//! Where the constant-environment sphere's albedo error comes from (issue 12 item 4, skin1's blue):
//! the f64 CPU solve of a sphere (R = 10 mm) of a preset under a constant environment, step by
//! step against the model's closed form phi(r) = alpha sinh(s r) / r (DESIGN 2):
//! - the lattice: phi at the inner nodes within a few spacings of the surface, against phi(r);
//! - the sample: phi interpolated at each display vertex's sample point, against phi(R - depth);
//! - the curvature: the baked mean curvature against 1 / R;
//! - the profile: phi(0) and the exitance M from the exact sample (the profile alone), and from
//!   the interpolated sample (what the interior surface computes);
//! - the surface nodes' exitance (the Shepard surface's source).
//!
//! ```sh
//! cargo run --release -p translucent-benches --bin env_sphere_error -- skin1 20 1.3 [grosjean|classical]
//! ```
//!
//! Arguments: preset, lattice cells across the sphere's 20 mm (render's `--resolution`), eta,
//! diffusion coefficient. Prints one block per channel.

use glam::DVec3;
use translucent::material::{DiffusionCoefficient, Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Scene};
use translucent::solver::transport::{
    curved_profile_from_sample, Boundary, ExitQuery, Optics, SurfaceReconstruction, Transport,
};
use translucent::solver::{self, CpuSolveParams};
use translucent::QuadGraph;

const RADIUS: f64 = 10.0;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let preset = args.get(1).map_or("skin1", String::as_str);
    let cells: u32 = args.get(2).map_or(Ok(20), |s| s.parse())?;
    let eta: f64 = args.get(3).map_or(Ok(1.3), |s| s.parse())?;
    let diffusion = match args.get(4).map_or("grosjean", String::as_str) {
        "classical" => DiffusionCoefficient::Classical,
        _ => DiffusionCoefficient::Grosjean,
    };
    let mut m = Material::preset(preset)?.with_diffusion(diffusion);
    m.eta = eta;
    let field = MaterialField::Homogeneous(m);
    let shape = Shape::Sphere { radius: RADIUS };
    let params = BakeParams {
        resolution: cells,
        ..Default::default()
    };
    let (graph, _) = QuadGraph::bake(&shape.triangulate(96), &shape, &params, &mut |_| {})?;
    let env = 1.0;
    let scene = Scene {
        lights: Vec::new(),
        environment: Environment::Constant([env; 3]),
    };
    let exit = ExitQuery::Moments;
    let solve_params = CpuSolveParams {
        transport: Transport {
            exit,
            surface: SurfaceReconstruction::Interior,
            ..Transport::default()
        },
        ..CpuSolveParams::default()
    };
    let solution = solver::solve(&graph, &field, &scene, None, &solve_params)?;
    let level = graph.finest();
    let inner = level.inner_count();
    let boundary = Boundary::new(eta, exit);
    let q = std::f64::consts::PI * env * boundary.diffuse_transmittance();
    let spacing = level.spacing;
    let samples = &graph.samples;
    let verts = graph.surface.positions.len();
    println!(
        "{preset} eta {eta} {diffusion:?}: {cells} cells, spacing {spacing:.3} mm, {inner} inner nodes, {verts} vertices, q {q:.5}"
    );
    let curv: Vec<f64> = samples.curvature.clone();
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    println!(
        "curvature: mean {:.5} (exact {:.5}), min {:.5}, max {:.5}; depth mean {:.4} mm",
        mean(&curv),
        1.0 / RADIUS,
        curv.iter().copied().fold(f64::INFINITY, f64::min),
        curv.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        mean(&samples.depth)
    );
    let radius_of = |v: usize| graph.surface.positions[v].length();
    println!(
        "display vertex radius: mean {:.5}",
        mean(&(0..verts).map(radius_of).collect::<Vec<_>>())
    );
    for c in 0..3 {
        let o = Optics::channel_with(&m.coefficients(), c, diffusion);
        let (d, s) = (o.d(), o.s());
        let h = boundary.h(o);
        let rhs = boundary.flux_gain * q;
        let g = s / (s * RADIUS).tanh() - 1.0 / RADIUS;
        let phi_r = rhs / (1.0 + h * g);
        let phi = |r: f64| phi_r * (s * r).sinh() / r * RADIUS / (s * RADIUS).sinh();
        let m_exact = boundary.exitance(d, phi_r, -g * phi_r, q);
        println!(
            "channel {c}: s {s:.4}, h {h:.4}, s*spacing {:.3}, closed-form albedo {:.5}",
            s * spacing,
            m_exact / q
        );
        if m_exact <= 0.0 {
            continue;
        }
        // The lattice: inner nodes within 3 spacings of the surface, by shell.
        for shell in 0..4 {
            let (lo, hi) = (
                shell as f64 * 0.75 * spacing,
                (shell + 1) as f64 * 0.75 * spacing,
            );
            let ratios: Vec<f64> = (0..inner)
                .filter_map(|i| {
                    let r = level.positions[i].length();
                    let z = RADIUS - r;
                    (z >= lo && z < hi).then(|| solution.phi[i][c] / phi(r) - 1.0)
                })
                .collect();
            if !ratios.is_empty() {
                println!(
                    "  lattice depth [{lo:.2}, {hi:.2}) mm: {} nodes, phi error mean {:+.3}%",
                    ratios.len(),
                    100.0 * mean(&ratios)
                );
            }
        }
        // Surface nodes: phi_s against phi(R) (the node sits on the surface), and their M.
        let surf: Vec<f64> = (0..level.surface_count())
            .map(|s_| solution.phi[inner + s_][c] / phi(level.positions[inner + s_].length()) - 1.0)
            .collect();
        let node_m: Vec<f64> = solution
            .exitance
            .iter()
            .map(|e| e[c] / m_exact - 1.0)
            .collect();
        println!(
            "  surface nodes: phi error mean {:+.3}%, node exitance error mean {:+.3}%",
            100.0 * mean(&surf),
            100.0 * mean(&node_m)
        );
        // Per vertex: the sample, the profile from the exact sample, from the lattice's.
        let mut sample_err = Vec::new();
        let mut m_exact_sample = Vec::new();
        let mut m_exact_sample_exact_h = Vec::new();
        let mut m_lattice = Vec::new();
        let mut phi0_err = Vec::new();
        let mut fixed_err = Vec::new();
        let mut m_fixed = Vec::new();
        for v in 0..verts {
            let x: DVec3 = graph.surface.positions[v];
            let r_v = x.length();
            let depth = samples.depth[v];
            // The sample point lies `depth` inside along the smoothed normal: take it radially.
            let p_exact = phi(r_v - depth);
            let p = samples.interpolate(v, &solution.phi)[c];
            sample_err.push(p / p_exact - 1.0);
            let k = samples.curvature[v];
            let (a0, a1) = curved_profile_from_sample(s, h, depth, p_exact, rhs, k);
            m_exact_sample.push(boundary.exitance(d, a0, a1, q) / m_exact - 1.0);
            let (b0, b1) = curved_profile_from_sample(s, h, depth, p_exact, rhs, 1.0 / r_v);
            m_exact_sample_exact_h.push(boundary.exitance(d, b0, b1, q) / m_exact - 1.0);
            let (c0, c1) = curved_profile_from_sample(s, h, depth, p, rhs, k);
            // The MLS spread of the sample's nodes along the normal and across it.
            let ps: DVec3 = samples.nodes[v]
                .iter()
                .zip(&samples.weights[v])
                .filter(|(&id, _)| id != u32::MAX)
                .map(|(&id, &w)| level.positions[id as usize] * w)
                .sum();
            let n = ps.normalize();
            let (mut m_nn, mut m_tt) = (0.0, 0.0);
            for (&id, &w) in samples.nodes[v].iter().zip(&samples.weights[v]) {
                if id != u32::MAX {
                    let dx = level.positions[id as usize] - ps;
                    let a = dx.dot(n);
                    m_nn += w * a * a;
                    m_tt += w * (dx.length_squared() - a * a);
                }
            }
            let bias = |pp: f64, rr: f64| {
                let (g0, dg0_plus) = curved_profile_from_sample(s, h, depth, pp, rr, k);
                let dg0 = dg0_plus - k * g0;
                let x = s * depth;
                let gd = g0 * x.cosh() + dg0 / s * x.sinh();
                let dgd = g0 * s * x.sinh() + dg0 * x.cosh();
                let phid = gd / (1.0 - k * depth);
                let phiz = (dgd + k * phid) / (1.0 - k * depth);
                let kappa = k / (1.0 - k * depth);
                let phizz = s * s * phid + 2.0 * kappa * phiz;
                0.5 * (phizz * m_nn - phiz * kappa * m_tt)
            };
            let (bp, br) = (bias(1.0, 0.0), bias(0.0, 1.0));
            let p_fixed = (p - rhs * br) / (1.0 + bp);
            let (f0, f1) = curved_profile_from_sample(s, h, depth, p_fixed, rhs, k);
            fixed_err.push(p_fixed / p_exact - 1.0);
            m_fixed.push(boundary.exitance(d, f0, f1, q) / m_exact - 1.0);
            phi0_err.push(c0 / phi_r - 1.0);
            m_lattice.push(boundary.exitance(d, c0, c1, q) / m_exact - 1.0);
        }
        let solver_vertex: Vec<f64> = solution
            .vertex_exitance
            .iter()
            .map(|e| e[c] / m_exact - 1.0)
            .collect();
        println!(
            "  vertex samples: phi error mean {:+.3}% (min {:+.3}, max {:+.3})",
            100.0 * mean(&sample_err),
            100.0 * sample_err.iter().copied().fold(f64::INFINITY, f64::min),
            100.0 * sample_err.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        );
        println!(
            "  M from the exact sample: baked H {:+.3}%, exact H {:+.3}%; from the lattice's sample {:+.3}% (phi0 {:+.4}%); solver's vertex exitance {:+.3}%",
            100.0 * mean(&m_exact_sample),
            100.0 * mean(&m_exact_sample_exact_h),
            100.0 * mean(&m_lattice),
            100.0 * mean(&phi0_err),
            100.0 * mean(&solver_vertex)
        );
        let sd = |v: &[f64]| {
            let m = mean(v);
            (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt()
        };
        println!(
            "  corrected sample: phi error mean {:+.3}% (sd {:.3}%), M {:+.3}% (sd {:.3}%; uncorrected sd {:.3}%)",
            100.0 * mean(&fixed_err),
            100.0 * sd(&fixed_err),
            100.0 * mean(&m_fixed),
            100.0 * sd(&m_fixed),
            100.0 * sd(&m_lattice)
        );
    }
    Ok(())
}
