//! The dipole gather's link windows (issue 15): the one link buffer is bound as up to
//! `LINK_WINDOWS` storage-buffer windows, each within the device's `maxStorageBufferRange` (the
//! README sphere's 11.5M links, 184 MB, exceed lavapipe's 128 MiB as one binding). A small mesh
//! with a forced small window spans several windows and must give the same J+ as one window, under
//! Khronos + synchronization validation; more links than the windows hold is a typed error made
//! before any GPU object.

use translucent::material::Material;
use translucent::mesh::shapes::Shape;
use translucent::solver::dipole::gpu::{device_link_window, link_window_step, LINK_WINDOWS};
use translucent::solver::dipole::{
    BoundaryModel, DipoleError, DipoleGatherPass, DipoleProfile, FaceClusterHierarchy, LinkParams,
    LinkSet,
};
use translucent::vk::{barrier, Access, Context};
use translucent_tests::GpuTest;

/// Windowed against one window, largest |difference| of the vertex exitance: the same links are
/// summed in the same order from the same bytes, only the binding they are read through differs.
const WINDOWED_VS_WHOLE: f32 = 0.0;

fn sphere_links() -> (FaceClusterHierarchy, LinkSet) {
    let mesh = Shape::Sphere { radius: 10.0 }.triangulate(10);
    let (tree, _) = FaceClusterHierarchy::build(&mesh).expect("hierarchy");
    let dipole = DipoleProfile::new(
        &Material::preset("marble").expect("preset"),
        BoundaryModel::Moments,
    );
    let (links, _) = LinkSet::build(&tree, &dipole, &LinkParams::default());
    (tree, links)
}

/// A leaf irradiance that differs per triangle and channel, so a link read from the wrong window
/// (another source, another form factor) changes the result.
fn irradiance(leaves: usize) -> Vec<[f64; 3]> {
    (0..leaves)
        .map(|i| {
            let x = i as f64;
            [
                0.5 + 0.5 * (0.37 * x).sin(),
                0.5 + 0.5 * (0.11 * x).cos(),
                (i % 7) as f64 / 6.0,
            ]
        })
        .collect()
}

fn gather(
    ctx: &Context,
    tree: &FaceClusterHierarchy,
    links: &LinkSet,
    window: Option<usize>,
) -> (Vec<[f32; 4]>, usize) {
    let mut pass =
        DipoleGatherPass::with_link_window(ctx, tree, links, None, window).expect("gather pass");
    pass.write_leaf_irradiance(&irradiance(tree.leaf_count()))
        .expect("irradiance");
    ctx.execute("dipole windows", |cb| {
        // SAFETY: `cb` is recording; the pass outlives the waited submission.
        unsafe {
            pass.record(ctx, cb, None);
            // why: the CPU reads what the vertex dispatch wrote.
            barrier::memory(ctx, cb, Access::ComputeWrite, Access::HostRead);
        }
        Ok(())
    })
    .expect("execute");
    let m = pass.read_vertex_exitance().expect("read");
    (m, pass.link_windows_used())
}

#[test]
fn a_gather_over_several_link_windows_equals_the_one_window_gather() {
    let gpu = GpuTest::new();
    let (tree, links) = sphere_links();
    let step = link_window_step(&gpu.ctx);
    // Three windows (the last partial): every window binding but the unused fourth is read.
    let window = links.len().div_ceil(3).next_multiple_of(step);
    assert!(
        window < links.len() && window < device_link_window(&gpu.ctx),
        "{} links, window {window}: the test needs several windows",
        links.len()
    );
    let (whole, one) = gather(&gpu.ctx, &tree, &links, None);
    let (windowed, used) = gather(&gpu.ctx, &tree, &links, Some(window));
    assert_eq!(one, 1, "the device window holds this small mesh's links");
    assert!(
        (2..=LINK_WINDOWS).contains(&used),
        "{used} windows of {window} for {} links",
        links.len()
    );
    assert!(
        whole.iter().flatten().all(|x| x.is_finite()) && whole.iter().any(|m| m[0] > 0.0),
        "the one-window gather is finite and lit"
    );
    let worst = whole
        .iter()
        .zip(&windowed)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
        .fold(0.0f32, f32::max);
    assert!(
        worst <= WINDOWED_VS_WHOLE,
        "windowed J+ differs from one window by up to {worst}"
    );
    gpu.finish();
}

#[test]
fn more_links_than_the_windows_hold_is_a_typed_error_before_any_gpu_work() {
    let gpu = GpuTest::new();
    let (tree, links) = sphere_links();
    let window = link_window_step(&gpu.ctx);
    assert!(
        links.len() > LINK_WINDOWS * window,
        "the test needs an overflow"
    );
    let err = DipoleGatherPass::with_link_window(&gpu.ctx, &tree, &links, None, Some(window))
        .err()
        .expect("too many links must be an error");
    match &err {
        DipoleError::TooManyLinks {
            links: n,
            max_links,
            max_range,
            ..
        } => {
            assert_eq!(*n, links.len());
            assert_eq!(*max_links, LINK_WINDOWS * window);
            assert_eq!(*max_range, gpu.ctx.limits().max_storage_buffer_range);
        }
        other => panic!("expected TooManyLinks, got {other}"),
    }
    assert!(
        err.to_string().contains("--link-tolerance"),
        "the message names the fix: {err}"
    );
    let bad = DipoleGatherPass::with_link_window(&gpu.ctx, &tree, &links, None, Some(0));
    assert!(matches!(bad, Err(DipoleError::Parameter { .. })));
    gpu.finish();
}
