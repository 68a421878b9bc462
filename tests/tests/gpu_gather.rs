//! Part B's irradiance gather (shadow maps + `IrradiancePass`) writing q straight into the GPU
//! solve's per-level q images (the interface of `solver::gpu`'s module doc), then the solve, in one
//! command buffer; compared with the f64 CPU reference on the same schedule. Tolerance 1%: the
//! gather's q is within 1e-3 of the reference where lit (its own test), the terminator nodes see
//! PCF instead of a hard n.l cut, and the solve adds < 1e-3 (gpu_diffusion.rs).

use translucent::frame::quadgraph::PASS_GATHER;
use translucent::frame::{FrameGraph, PASS_SHADOW};
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::GpuMesh;
use translucent::quadgraph::BakeParams;
use translucent::render::{q_scale_for, GatherScene, IrradiancePass, ShadowMaps, ShadowMapsDesc};
use translucent::scene::{Environment, Scene};
use translucent::solver::gpu::{GpuDiffusion, GpuSolveParams};
use translucent::solver::{self, rel_rms, CpuSolveParams};
use translucent::vk::VkError;
use translucent::{ObjectParams, QuadGraph, TranslucentObject};
use translucent_tests::{render_once, solve_once, GpuTest};

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
    ctx.execute("shadow maps + gather", |cb| {
        let mut graph = FrameGraph::new(ctx);
        let (shadows, caster, pass, sets, solve) = (&shadows, &caster, &pass, &sets, &solve);
        graph
            .pass(PASS_SHADOW)
            .uses(shadows.uses(caster))
            .record(move |p| {
                // SAFETY: inside the pass declaring the shadow maps' uses; everything outlives
                // the waited submission.
                unsafe { shadows.record(p.ctx, p.cb, caster) };
                Ok(())
            });
        // The atlas once, then every level's images (a pass declares each resource once).
        let uses = (0..levels).flat_map(|h| {
            IrradiancePass::uses(
                shadows,
                solve.surface_position(h).unwrap(),
                solve.surface_normal(h).unwrap(),
                solve.q_image(h).unwrap(),
            )
            .into_iter()
            .skip(usize::from(h > 0))
        });
        graph.pass(PASS_GATHER).uses(uses).record(move |p| {
            // SAFETY: inside the pass declaring every level's gather uses; everything outlives
            // the waited submission.
            unsafe {
                pass.record_scene(p.ctx, p.cb, &uniforms);
                for set in sets {
                    pass.record(p.ctx, p.cb, set, q_scale, eta as f32)
                        .map_err(|e| VkError::InvalidArgument {
                            what: "gather".into(),
                            problem: e.to_string(),
                        })?;
                }
            }
            Ok(())
        });
        // SAFETY: `cb` is recording outside a rendering scope; everything outlives the wait.
        unsafe { graph.execute(cb, None, false) }.map_err(|e| VkError::InvalidArgument {
            what: "frame graph".into(),
            problem: e.to_string(),
        })?;
        Ok(())
    })
    .unwrap();
    solve_once(ctx, &mut solve, false);
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
    assert!(j.iter().flatten().all(|v| v.is_finite()));
    let err = rel_rms(&j, &cpu.j_plus_clamped);
    println!("gathered q -> GPU solve vs CPU: relative RMS of J+ {err:.2e}");
    assert!(err < 1e-2, "relative RMS {err}");
    assert_eq!(solve.iterations_run(ctx).unwrap(), vec![ITERATIONS; levels]);
    drop(solve);
    drop(pass);
    drop(shadows);
    drop(caster);
    gpu.finish();
}

/// A QuadGraph `TranslucentObject` (shadow maps + gather + solve, J+ written into the displayed
/// mesh, shaded) rendered by the headless host, against the same renderer showing the CPU reference's vertex J+ (same
/// schedule); plus its CPU-side report (residual, energy) from the GPU's phi.
#[test]
fn gpu_frame_renders_like_the_cpu_reference() {
    use translucent::headless::{ExitanceMesh, FrameDesc, HeadlessRenderer};
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
    let render_mesh = ExitanceMesh {
        mesh: graph.surface.clone(),
        exitance: cpu.vertex_j_plus.clone(),
        eta: field.eta(),
    };
    let desc = FrameDesc {
        width: 64,
        height: 64,
        specular: false,
        ..Default::default()
    };
    let mut renderer = HeadlessRenderer::new(ctx, &render_mesh, &scene, &desc).unwrap();
    let reference = renderer.render_frame(ctx).unwrap().image;
    drop(renderer);
    let mut object = TranslucentObject::new(
        ctx,
        std::sync::Arc::new(graph.clone()),
        &field,
        &scene,
        &ObjectParams {
            solve: solve_params,
            specular: false,
            single_level_nodes: 0,
            // why: compared with the CPU reference's image, which has no single scattering.
            single_scattering: None,
            ..ObjectParams::default()
        },
    )
    .unwrap();
    let (captured, _) = render_once(ctx, &mut object, desc.width, desc.height);
    let (mut diff, mut sum) = (0.0f64, 0.0f64);
    for (a, b) in captured.image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            assert!(a[c].is_finite());
            diff += f64::from((a[c] - b[c]).abs());
            sum += f64::from(b[c].abs());
        }
    }
    let report = object
        .quadgraph()
        .expect("quadgraph")
        .report(ctx, &field, &scene, None)
        .unwrap();
    let cpu_residual = cpu.residual;
    println!(
        "object image relative L1 {:.2e}; passes {:?}; report {report:?}; CPU residual {cpu_residual:?}",
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
    drop(object);
    gpu.finish();
}
