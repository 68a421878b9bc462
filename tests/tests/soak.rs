//! Soak, CI size (issue 6 item 4; the long run is `benches/src/bin/soak.rs --frames 10000`):
//! 100 frames of a small sphere in which every frame changes the light (`GpuFrame::set_lights`),
//! the material (`set_material`: drifting homogeneous coefficients, every fourth frame a
//! heterogeneous split with another eta) and the shape (`deform`: a twist of varying angle, an
//! affine squash, the identity), recorded as a host would with
//! `HeadlessRenderer::render_frame_after`. Asserts: no validation message (synchronization
//! validation on), no NaN or Inf in J+ (surface nodes and display vertices) or in the image every
//! 10 frames and at the end, and the allocator flat: live allocations, allocated bytes and memory
//! blocks identical at frame 10 and at the end.

use translucent::material::MaterialField;
use translucent::mesh::shapes::Shape;
use translucent::mesh::GpuMesh;
use translucent::quadgraph::BakeParams;
use translucent::render::{FrameDesc, HeadlessRenderer};
use translucent::solver::gpu::{GpuFrame, GpuSolveParams};
use translucent::QuadGraph;
use translucent_benches::soak::{deformation_at, material_at, scene_at};
use translucent_tests::GpuTest;

const FRAMES: usize = 100;
const CHECK_EVERY: usize = 10;

#[test]
fn a_hundred_frames_of_changing_light_material_and_shape_stay_finite_and_flat() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let shape = Shape::Sphere { radius: 10.0 };
    let bake = BakeParams {
        resolution: 8,
        levels: 2,
        ..Default::default()
    };
    let graph: QuadGraph = QuadGraph::bake(&shape.triangulate(12), &shape, &bake, &mut |_| {})
        .unwrap()
        .0;
    // 16 iterations per level and frame (warm-started): the soak is about stability over many
    // edits, the accuracy of a converged solve is gpu_diffusion.rs's and gpu_edit.rs's.
    let params = GpuSolveParams {
        iterations: vec![16],
        tolerance: 1e-4,
        warm_start: true,
        ..Default::default()
    };
    let field = material_at(0).expect("material");
    let scene = scene_at(0);
    let n = graph.surface.positions.len();
    let mut renderer = HeadlessRenderer::new(
        ctx,
        &translucent::render::Scene {
            mesh: graph.surface.clone(),
            exitance: vec![[0.0; 3]; n],
            lights: scene.lights.clone(),
            eta: field.eta(),
        },
        &FrameDesc {
            width: 48,
            height: 48,
            ..Default::default()
        },
    )
    .unwrap();
    let mut frame = GpuFrame::new(ctx, &graph, &field, &scene, &params).unwrap();
    frame.solve.bind_mesh(ctx, renderer.mesh()).unwrap();
    let caster = GpuMesh::new(ctx, &graph.surface, &vec![[0.0; 3]; n]).unwrap();
    let mut at_frame_10 = None;
    let mut kinds = [0usize; 2];
    for i in 0..FRAMES {
        frame.set_lights(&graph, &scene_at(i)).unwrap();
        let field = material_at(i).expect("material");
        kinds[usize::from(matches!(field, MaterialField::Homogeneous(_)))] += 1;
        frame.set_material(ctx, &graph, &field).unwrap();
        frame
            .deform(ctx, &graph, &deformation_at(i), &[renderer.mesh(), &caster])
            .unwrap();
        let mut failed = None;
        let captured = renderer
            .render_frame_after(ctx, |cb, profiler| {
                // SAFETY: `cb` is recording; frame and caster outlive the waited frame.
                failed = unsafe { frame.record(ctx, cb, &caster, Some(profiler)) }.err();
            })
            .unwrap();
        assert!(failed.is_none(), "frame {i}: {failed:?}");
        // Each edit pass shows in the profiler exactly in the frames that need it.
        let has = |name: &str| captured.passes.contains_key(name);
        assert_eq!(
            has("edit derive weights"),
            i % 4 == 3,
            "frame {i}: {:?}",
            captured.passes
        );
        assert_eq!(has("edit deform"), i % 10 != 5, "frame {i}");
        assert!(
            has("edit deform mesh") && has("diffusion jacobi"),
            "frame {i}"
        );
        if i % CHECK_EVERY == CHECK_EVERY - 1 || i + 1 == FRAMES {
            let j = frame.solve.read_j_plus(ctx).unwrap();
            assert!(
                j.iter().flatten().all(|v| v.is_finite() && *v >= 0.0),
                "frame {i}: J+"
            );
            assert!(j.iter().flatten().any(|v| *v > 0.0), "frame {i}: black");
            let v = frame.solve.read_vertex_j_plus(ctx).unwrap();
            assert!(
                v.iter().flatten().all(|v| v.is_finite()),
                "frame {i}: vertex J+"
            );
            assert!(
                captured
                    .image
                    .pixels
                    .iter()
                    .flatten()
                    .all(|c| c.is_finite()),
                "frame {i}: image"
            );
            gpu.assert_no_messages();
        }
        if i == 10 {
            at_frame_10 = Some(ctx.allocator_usage());
        }
    }
    let end = ctx.allocator_usage();
    println!(
        "allocator (allocations, bytes, block bytes): frame 10 {at_frame_10:?}, end {end:?}; \
         {} heterogeneous / {} homogeneous frames",
        kinds[0], kinds[1]
    );
    assert_eq!(Some(end), at_frame_10, "allocator grew");
    drop((frame, caster, renderer));
    gpu.finish();
}
