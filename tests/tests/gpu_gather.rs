//! Part B's irradiance gather (shadow maps + `IrradiancePass`) writing q straight into the GPU
//! solve's per-level q images (the interface of `solver::gpu`'s module doc), then the solve, in one
//! command buffer; compared with the f64 CPU reference on the same schedule. Tolerance 1%: the
//! gather's q is within 1e-3 of the reference where lit (its own test), the terminator nodes see
//! PCF instead of a hard n.l cut, and the solve adds < 1e-3 (gpu_diffusion.rs).

use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::GpuMesh;
use translucent::quadgraph::BakeParams;
use translucent::render::{q_scale_for, GatherScene, IrradiancePass, ShadowMaps, ShadowMapsDesc};
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams};
use translucent::solver::{self, CpuSolveParams};
use translucent::vk::{Access, VkError};
use translucent::QuadGraph;
use translucent_tests::GpuTest;

#[test]
fn gathered_q_feeds_the_gpu_solve() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let ball = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 16,
        levels: 2,
        ..Default::default()
    };
    let graph: QuadGraph = QuadGraph::bake(&ball.triangulate(32), &ball, &params, &mut |_| {})
        .unwrap()
        .0;
    let scene = Scene {
        lights: vec!["dir:-0.3,-1,0.2:2,2,2".parse().unwrap()],
        environment: Environment::Constant([0.05; 3]),
    };
    let field = MaterialField::Homogeneous(Material::preset("marble").unwrap());
    let eta = field.eta();
    const ITERATIONS: u32 = 64;
    let mut solve = GpuDiffusion::new(
        ctx,
        &graph,
        &field,
        &GpuSolveParams {
            iterations: vec![ITERATIONS],
            tolerance: 0.0,
            ..Default::default()
        },
    )
    .unwrap();
    let q_scale = q_scale_for(&scene, graph.finest(), eta);
    solve.set_q_scale(q_scale);

    let caster = GpuMesh::new(
        ctx,
        &graph.surface,
        &vec![[0.0; 3]; graph.surface.positions.len()],
    )
    .unwrap();
    let mut shadows = ShadowMaps::new(ctx, &ShadowMapsDesc::default()).unwrap();
    shadows
        .set_lights(&scene.lights, graph.finest().bounding_sphere(), true)
        .unwrap();
    let levels = graph.levels.len();
    let pass = IrradiancePass::new(ctx, levels as u32).unwrap();
    let sets: Vec<_> = (0..levels)
        .map(|h| {
            pass.bind_level(
                ctx,
                &shadows,
                solve.surface_position(h).unwrap(),
                solve.surface_normal(h).unwrap(),
                solve.q_image(h).unwrap(),
                solve.surface_rows(h).unwrap(),
            )
            .unwrap()
        })
        .collect();
    let uniforms = GatherScene::new(&scene, &shadows).unwrap();
    ctx.execute("gather + solve", |cb| {
        // SAFETY: `cb` is recording; everything outlives the waited submission.
        unsafe {
            shadows.record(ctx, cb, &caster, None);
            pass.record_scene(ctx, cb, &uniforms);
            for (h, set) in sets.iter().enumerate() {
                pass.record(
                    ctx,
                    cb,
                    set,
                    &shadows,
                    solve.q_image(h).unwrap(),
                    Access::ComputeReadWrite,
                    q_scale,
                    eta as f32,
                    None,
                )
                .map_err(|e| VkError::InvalidArgument {
                    what: "gather".into(),
                    problem: e.to_string(),
                })?;
            }
            solve.record(ctx, cb, None);
        }
        Ok(())
    })
    .unwrap();
    let j = solve.read_j_plus(ctx).unwrap();
    let cpu = solver::solve(
        &graph,
        &field,
        &scene,
        None,
        &CpuSolveParams {
            iterations: vec![ITERATIONS as usize],
            tolerance: 0.0,
            exact: false,
            ..Default::default()
        },
    )
    .unwrap();
    let (mut d2, mut r2) = (0.0, 0.0);
    for (g, c) in j.iter().zip(&cpu.j_plus_clamped) {
        for ch in 0..3 {
            assert!(g[ch].is_finite());
            d2 += (f64::from(g[ch]) - c[ch]).powi(2);
            r2 += c[ch] * c[ch];
        }
    }
    let err = (d2 / r2).sqrt();
    println!("gathered q -> GPU solve vs CPU: relative RMS of J+ {err:.2e}");
    assert!(err < 1e-2, "relative RMS {err}");
    assert_eq!(solve.iterations_run(ctx).unwrap(), vec![ITERATIONS; levels]);
    drop(solve);
    drop(pass);
    drop(shadows);
    drop(caster);
    gpu.finish();
}

/// `GpuFrame` (shadow maps + gather + solve, J+ written into the displayed mesh) rendered by the
/// headless renderer, against the same renderer showing the CPU reference's vertex J+ (same
/// schedule); plus its CPU-side report (residual, energy) from the GPU's phi.
#[test]
fn gpu_frame_renders_like_the_cpu_reference() {
    use translucent::render::{FrameDesc, HeadlessRenderer, Scene as RenderScene};
    use translucent::solver::gpu::GpuFrame;
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let ball = Shape::Sphere { radius: 10.0 };
    let params = BakeParams {
        resolution: 12,
        levels: 2,
        ..Default::default()
    };
    let graph = QuadGraph::bake(&ball.triangulate(32), &ball, &params, &mut |_| {})
        .unwrap()
        .0;
    let scene = Scene {
        lights: vec!["dir:-0.3,-1,0.2:2,2,2".parse().unwrap()],
        environment: Environment::Constant([0.05; 3]),
    };
    let field = MaterialField::Homogeneous(Material::preset("skimmilk").unwrap());
    let solve_params = GpuSolveParams {
        iterations: vec![48],
        tolerance: 0.0,
        ..Default::default()
    };
    let cpu = solver::solve(
        &graph,
        &field,
        &scene,
        None,
        &CpuSolveParams {
            iterations: vec![48],
            tolerance: 0.0,
            exact: false,
            ..Default::default()
        },
    )
    .unwrap();
    let render_scene = RenderScene {
        mesh: graph.surface.clone(),
        exitance: cpu.vertex_j_plus.clone(),
        lights: scene.lights.clone(),
        eta: field.eta(),
    };
    let desc = FrameDesc {
        width: 64,
        height: 64,
        specular: false,
        ..Default::default()
    };
    let mut renderer = HeadlessRenderer::new(ctx, &render_scene, &desc).unwrap();
    let reference = renderer.render_frame(ctx).unwrap().image;
    renderer
        .set_exitance(ctx, &vec![[0.0; 3]; graph.surface.positions.len()])
        .unwrap();
    let mut frame = GpuFrame::new(ctx, &graph, &field, &scene, &solve_params).unwrap();
    frame.solve.bind_mesh(ctx, renderer.mesh()).unwrap();
    let caster = GpuMesh::new(
        ctx,
        &graph.surface,
        &vec![[0.0; 3]; graph.surface.positions.len()],
    )
    .unwrap();
    let mut failed = None;
    let captured = renderer
        .render_frame_after(ctx, |cb, profiler| {
            // SAFETY: `cb` is recording; `frame` and `caster` outlive the waited frame.
            failed = unsafe { frame.record(ctx, cb, &caster, Some(profiler)) }.err();
        })
        .unwrap();
    assert!(failed.is_none(), "{failed:?}");
    let (mut diff, mut sum) = (0.0f64, 0.0f64);
    for (a, b) in captured.image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            assert!(a[c].is_finite());
            diff += f64::from((a[c] - b[c]).abs());
            sum += f64::from(b[c].abs());
        }
    }
    let report = frame
        .report(ctx, &graph, &field, &scene, None, &solve_params)
        .unwrap();
    let cpu_residual = cpu.residual;
    println!(
        "GpuFrame image relative L1 {:.2e}; passes {:?}; report {report:?}; CPU residual {cpu_residual:?}",
        diff / sum,
        captured.passes
    );
    assert!(sum > 0.0);
    assert!(diff / sum < 1e-2, "relative L1 {}", diff / sum);
    assert_eq!(report.iterations, vec![48, 48]);
    for (c, &r) in report.residual.iter().enumerate() {
        // Same schedule: the GPU's residual is the CPU's, up to the gathered q's fp16 rounding.
        assert!(
            r.is_finite() && (r - cpu_residual[c]).abs() <= 0.05 * cpu_residual[c] + 1e-3,
            "{r} vs {}",
            cpu_residual[c]
        );
        let e = report.energy;
        assert!(
            (e.exitance[c] - cpu.energy.exitance[c]).abs()
                <= 1e-2 * cpu.energy.transmitted_input[c]
        );
    }
    for pass in ["shadow maps", "diffusion jacobi", "diffusion j+"] {
        let present = captured.passes.keys().any(|k| k.contains(pass));
        println!("{pass}: {present}");
    }
    assert!(captured.passes.contains_key("diffusion jacobi"));
    drop(frame);
    drop(caster);
    drop(renderer);
    gpu.finish();
}
