//! Where the GPU frame's gathered q (shadow maps, 3x3 PCF, normal offset, fp16) differs from the
//! f64 reference's (a ray cast per surface node): the marble torus of `render --shape torus
//! --size-mm 20` under a grazing directional light, per finest surface node, binned by n.l and
//! by whether the ray cast finds the node shadowed. benches/RESULTS.md, "Loose ends (wave 7)".
//!
//!     cargo run --release -p translucent-benches --bin torus_band [-- LIGHT_DIR [RESOLUTION [TOLERANCE]]]

use std::sync::Arc;

use translucent::headless::HeadlessHost;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Environment, Light, Scene};
use translucent::vk::{Access, Context, ContextDesc, ImageReadback};
use translucent::{ObjectParams, QuadGraph, TranslucentObject};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let dir = args.first().map_or("1,-0.18,0.3", String::as_str);
    let resolution: u32 = args.get(1).map_or(Ok(24), |s| s.parse())?;
    let torus = Shape::Torus {
        major: 7.0,
        minor: 3.0,
    };
    let bake = BakeParams {
        resolution,
        levels: 3,
        ..BakeParams::default()
    };
    let graph = QuadGraph::bake(&torus.triangulate(96), &torus, &bake, &mut |_| {})?.0;
    let light: Light = format!("dir:{dir}:5,5,5").parse()?;
    let scene = Scene {
        lights: vec![light],
        environment: Environment::None,
    };
    let marble = Material::preset("marble")?;
    let field = MaterialField::Homogeneous(Material::new(marble.sigma_s, marble.sigma_a, 1.0)?);
    let ctx = Context::headless(&ContextDesc::default())?;
    let tolerance: f64 = args
        .get(2)
        .map_or(Ok(translucent::defaults::TOLERANCE), |s| s.parse())?;
    let settings = translucent::defaults::Settings {
        tolerance,
        single_scattering: None,
        bounce: translucent::frame::BounceMode::Off,
        ..translucent::defaults::Settings::default()
    }
    .with_source(translucent::solver::transport::Source::BoundaryFlux);
    let mut object = TranslucentObject::new(
        &ctx,
        Arc::new(graph.clone()),
        &field,
        &scene,
        &ObjectParams {
            specular: false,
            ..settings.object_params()
        },
    )?;
    let mut host = HeadlessHost::new(&ctx, 64, 64)?;
    host.render(&ctx, &mut object)?;
    let method = object.quadgraph().ok_or("a QuadGraph object")?;
    let level = graph.finest();
    let finest = graph.levels.len() - 1;
    let gathered = ImageReadback::capture(
        &ctx,
        method.solve().q_image(finest).ok_or("no q image")?,
        Access::ComputeReadWrite,
    )?;
    let unscale = 1.0 / f64::from(method.q_scale());
    let inner = level.inner_count();
    let gpu: Vec<f64> = level.packing.texels[inner..]
        .iter()
        .map(|&[u, v]| f64::from(gathered.pixel(u, v)[0]) * unscale)
        .collect();
    let shadowed = scene.surface_irradiance(level, field.eta(), Some(&torus));
    let open = scene.surface_irradiance(level, field.eta(), None);
    let Light::Directional { direction, .. } = scene.lights[0] else {
        unreachable!("a directional light")
    };
    let l = -direction.normalize();
    // Bins: by cos(n, l) for nodes the ray cast finds lit, and the shadowed nodes apart.
    let bins = [0.0, 0.05, 0.1, 0.2, 0.4, 0.7, 1.01];
    println!("| nodes | n.l | ray cast lit? | sum q f64 | sum q GPU | GPU / f64 | nodes GPU > 1.1 x f64 |");
    println!("|---|---|---|---|---|---|---|");
    let (mut all_f, mut all_g) = (0.0, 0.0);
    for lit in [true, false] {
        for w in bins.windows(2) {
            let (mut n, mut f, mut g, mut over) = (0, 0.0, 0.0, 0);
            for s in 0..level.surface_count() {
                let cos = level.surface_normals[s].dot(l);
                let is_lit = shadowed[s][0] > 0.5 * open[s][0] && open[s][0] > 0.0;
                if cos < w[0] || cos >= w[1] || is_lit != lit || open[s][0] <= 0.0 {
                    continue;
                }
                n += 1;
                f += shadowed[s][0];
                g += gpu[s];
                over += usize::from(gpu[s] > 1.1 * shadowed[s][0] + 1e-6);
            }
            all_f += f;
            all_g += g;
            if n > 0 {
                println!(
                    "| {n} | [{:.2}, {:.2}) | {} | {f:.1} | {g:.1} | {:.3} | {over} |",
                    w[0],
                    w[1],
                    if lit { "lit" } else { "shadowed" },
                    if f > 0.0 { g / f } else { f64::NAN }
                );
            }
        }
    }
    println!("total over lit-side nodes: f64 {all_f:.1}, GPU {all_g:.1}");
    let q_ratio = gpu
        .iter()
        .zip(&shadowed)
        .filter(|(_, c)| c[0] > 1e-3)
        .map(|(g, c)| g / c[0])
        .fold(0.0_f64, f64::max);
    println!("surface nodes: the largest GPU / f64 q {q_ratio:.3}");
    // The exitance per display vertex: the GPU solve's against the f64 exact solve's.
    let cpu = translucent::solver::solve(
        &graph,
        &field,
        &scene,
        Some(&torus),
        &translucent::solver::CpuSolveParams::default(),
    )?;
    let nodes = method.solve().read_j_plus(&ctx)?;
    let node_ratio = nodes
        .iter()
        .zip(&cpu.j_plus_clamped)
        .filter(|(_, c)| c[0] > 1e-3)
        .map(|(g, c)| f64::from(g[0]) / c[0])
        .fold(0.0_f64, f64::max);
    println!("surface nodes: the largest GPU / f64 J+ {node_ratio:.3}");
    let phi = method.solve().read_phi(&ctx, finest)?;
    // Nodes the ray cast finds shadowed (under half the unoccluded q) that the shadow maps light.
    let leaks: Vec<usize> = (0..level.surface_count())
        .filter(|&s| open[s][0] > 0.0 && shadowed[s][0] < 0.5 * open[s][0])
        .filter(|&s| gpu[s] > 0.1 * open[s][0])
        .collect();
    let leaked: f64 = leaks.iter().map(|&s| gpu[s] - shadowed[s][0]).sum();
    println!(
        "shadowed nodes the shadow maps light (> 0.1 of unoccluded q): {} of {}, {leaked:.2} q in all",
        leaks.len(),
        level.surface_count()
    );
    for &s in leaks.iter().take(6) {
        println!(
            "  node {s}: q GPU {:.3}, ray cast {:.3}, unoccluded {:.3}, n.l {:.3}, at {:.2}",
            gpu[s],
            shadowed[s][0],
            open[s][0],
            level.surface_normals[s].dot(l),
            level.positions[inner + s]
        );
    }
    let mut by_ratio: Vec<(f64, usize)> = nodes
        .iter()
        .zip(&cpu.j_plus_clamped)
        .enumerate()
        .filter(|(_, (_, c))| c[0] > 1e-3)
        .map(|(s, (g, c))| (f64::from(g[0]) / c[0], s))
        .collect();
    by_ratio.sort_by(|a, b| b.0.total_cmp(&a.0));
    for &(r, s) in by_ratio.iter().take(4) {
        println!(
            "  node {s}: J+ GPU/f64 {r:.3} (f64 {:.4}), q GPU {:.4} f64 {:.4}, phi GPU {:.4} f64 {:.4}, n.l {:.3}, at {:.2}",
            cpu.j_plus_clamped[s][0],
            gpu[s],
            shadowed[s][0],
            phi[inner + s][0],
            cpu.phi[inner + s][0],
            level.surface_normals[s].dot(l),
            level.positions[inner + s]
        );
    }
    let vertex = method.solve().read_vertex_j_plus(&ctx)?;
    let mut worst = Vec::new();
    for (v, (g, c)) in vertex.iter().zip(&cpu.vertex_j_plus).enumerate() {
        let (g, c) = (f64::from(g[0]), f64::from(c[0]));
        if c > 1e-3 {
            worst.push((g / c, v));
        }
    }
    worst.sort_by(|a, b| b.0.total_cmp(&a.0));
    let over = worst.iter().filter(|w| w.0 > 1.1).count();
    println!(
        "display vertices: {} lit, GPU > 1.1 x f64 at {over}; worst {:?}",
        worst.len(),
        &worst[..5.min(worst.len())]
    );
    for &(r, v) in worst.iter().take(5) {
        let p = graph.surface.positions[v];
        let n = graph.surface.normals[v];
        println!("  vertex {v} ratio {r:.3} at {p:.2} n.l {:.3}", n.dot(l));
    }
    drop(host);
    drop(object);
    Ok(())
}
