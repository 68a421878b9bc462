//! Soak, CI size (issue 6 item 4; the long run is `benches/src/bin/soak.rs --frames 10000`):
//! 100 frames of a small sphere in which every frame changes the light (`TranslucentObject::set_lights`),
//! the material (`set_material`: drifting homogeneous coefficients, every fourth frame a
//! heterogeneous split with another eta) and the shape (`deform`: a twist of varying angle, an
//! affine squash, the identity), recorded as a host would
//! (`HeadlessHost::render`). Asserts: no validation message (synchronization
//! validation on), no NaN or Inf in J+ (surface nodes and display vertices) or in the image every
//! 10 frames and at the end, and the allocator flat: live allocations, allocated bytes and memory
//! blocks identical at frame 10 and at the end.

use translucent::headless::HeadlessHost;
use translucent::material::MaterialField;
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::solver::gpu::GpuSolveParams;
use translucent::QuadGraph;
use translucent_benches::soak::{deformation_at, material_at, scene_at};
use translucent_tests::{quadgraph_object, GpuTest};

const FRAMES: usize = 100;
const CHECK_EVERY: usize = 10;

/// The allocator's totals once the last frame's edits are released: a frame with nothing
/// changed (the object lets go of the staged edits it held for the last frame), waited, then
/// every completed frame's releases done. Without it the totals would differ by the staging
/// buffers of whichever edits the last frame happened to make.
fn settled_usage(
    ctx: &translucent::vk::Context,
    host: &mut HeadlessHost,
    object: &mut translucent::TranslucentObject,
) -> (usize, u64, u64) {
    let (captured, _) = host.render(ctx, object).expect("quiet frame");
    ctx.frame_completed(captured.frame);
    ctx.allocator_usage()
}

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
        ..Default::default()
    };
    let field = material_at(0).expect("material");
    let scene = scene_at(0);
    let mut object = quadgraph_object(ctx, &graph, &field, &scene, params);
    let mut host = HeadlessHost::new(ctx, 48, 48).unwrap();
    let mut at_frame_10 = None;
    let mut kinds = [0usize; 2];
    for i in 0..FRAMES {
        object.set_lights(&scene_at(i)).unwrap();
        let field = material_at(i).expect("material");
        kinds[usize::from(matches!(field, MaterialField::Homogeneous(_)))] += 1;
        object.set_material(ctx, &field).unwrap();
        object.deform(ctx, &deformation_at(i)).unwrap();
        let (captured, _report) = host
            .render(ctx, &mut object)
            .unwrap_or_else(|e| panic!("frame {i}: {e:?}"));
        // Each edit pass shows in the profiler exactly in the frames that need it. The
        // heterogeneous materials' weights are derived in the sweep by default
        // (`HeterogeneousWeights::Derived`): no derivation pass, whatever the material.
        let has = |name: &str| captured.passes.contains_key(name);
        assert!(
            !has("edit derive weights"),
            "frame {i}: {:?}",
            captured.passes
        );
        assert_eq!(has("edit deform"), i % 10 != 5, "frame {i}");
        assert!(
            has("edit deform mesh") && has("diffusion jacobi"),
            "frame {i}"
        );
        if i % CHECK_EVERY == CHECK_EVERY - 1 || i + 1 == FRAMES {
            let j = object
                .quadgraph()
                .expect("quadgraph")
                .solve()
                .read_j_plus(ctx)
                .unwrap();
            assert!(
                j.iter().flatten().all(|v| v.is_finite() && *v >= 0.0),
                "frame {i}: J+"
            );
            assert!(j.iter().flatten().any(|v| *v > 0.0), "frame {i}: black");
            let v = object
                .quadgraph()
                .expect("quadgraph")
                .solve()
                .read_vertex_j_plus(ctx)
                .unwrap();
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
            at_frame_10 = Some(settled_usage(ctx, &mut host, &mut object));
        }
    }
    let end = settled_usage(ctx, &mut host, &mut object);
    println!(
        "allocator (allocations, bytes, block bytes): frame 10 {at_frame_10:?}, end {end:?}; \
         {} heterogeneous / {} homogeneous frames",
        kinds[0], kinds[1]
    );
    assert_eq!(Some(end), at_frame_10, "allocator grew");
    drop((object, host));
    gpu.finish();
}
