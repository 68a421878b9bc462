//! Shared helpers for the integration tests: mesh directory, validation-on GPU contexts, image
//! comparison with named tolerances.
//!
//! ```no_run
//! let gpu = translucent_tests::GpuTest::new();
//! // ... use gpu.ctx ...
//! gpu.finish(); // drops the context and fails on any validation warning or error
//! ```

use std::path::{Path, PathBuf};

use translucent::vk::{Context, ContextDesc, LinearImage, ValidationLog};

/// The workspace root (parent of this crate).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default()
}

/// The path of test mesh `name` (e.g. `"spot.obj"`), or `None` with a printed "skipped" message when
/// it is missing. With `CI` set a missing mesh fails the test instead.
pub fn test_mesh(name: &str) -> Option<PathBuf> {
    let dir = std::env::var_os("TRANSLUCENT_MESH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("../shared/meshes"));
    let path = dir.join(name);
    if path.is_file() {
        return Some(path);
    }
    let message = format!(
        "test mesh {} not found (set TRANSLUCENT_MESH_DIR)",
        path.display()
    );
    assert!(std::env::var_os("CI").is_none(), "{message}");
    eprintln!("skipped: {message}");
    None
}

/// Test mesh `name` loaded, validated, normalized to 50 mm (as `translucent render --mesh` does)
/// and baked at `resolution` cells with `levels` levels, or `None` where [`test_mesh`] skips.
pub fn bake_test_mesh(name: &str, resolution: u32, levels: u32) -> Option<translucent::QuadGraph> {
    use translucent::mesh::{MeshSolid, TriMesh, ValidateOptions};
    use translucent::quadgraph::BakeParams;
    let path = test_mesh(name)?;
    let mut mesh = TriMesh::load_obj(&path).expect("load the test mesh");
    mesh.validate(&ValidateOptions::default())
        .expect("a valid test mesh");
    let (mut mesh, _) = mesh.normalized(50.0).expect("normalize the test mesh");
    mesh.compute_normals();
    let solid = MeshSolid::new(mesh.clone()).expect("a closed test mesh");
    let params = BakeParams {
        resolution,
        levels,
        ..Default::default()
    };
    let (graph, _) =
        translucent::QuadGraph::bake(&mesh, &solid, &params, &mut |_| {}).expect("bake");
    Some(graph)
}

/// Where tests write their outputs (`target/test-output/`), created on demand.
pub fn test_output_dir() -> PathBuf {
    let dir = workspace_root().join("target").join("test-output");
    let _ = std::fs::create_dir_all(&dir);
    dir
}

/// A validation-on context on lavapipe (or `TRANSLUCENT_DEVICE`), checked for messages at the end.
pub struct GpuTest {
    pub ctx: Context,
    log: ValidationLog,
}

impl GpuTest {
    /// Creates the context with Khronos validation and synchronization validation. Panics with
    /// what to install when there is no Vulkan device.
    pub fn new() -> GpuTest {
        let device = std::env::var("TRANSLUCENT_DEVICE")
            .ok()
            .filter(|d| !d.is_empty())
            .unwrap_or_else(|| "llvmpipe".into());
        let desc = ContextDesc {
            validation: true,
            echo_validation: true,
            device_name: Some(device),
            frames_in_flight: 2,
        };
        let ctx = Context::headless(&desc).unwrap_or_else(|e| {
            panic!(
                "this test needs a Vulkan device with the validation layer: {e}\n\
                 install them with `apt-get install mesa-vulkan-drivers vulkan-validationlayers`"
            )
        });
        let log = ctx.validation_log();
        GpuTest { ctx, log }
    }

    /// Fails on any message so far (the context stays usable).
    pub fn assert_no_messages(&self) {
        let messages = self.log.take();
        assert!(
            messages.is_empty(),
            "{} validation message(s):\n{}",
            messages.len(),
            join(&messages)
        );
    }

    /// Drops the context (device, then instance) and fails on any message, including those the
    /// layer emits at destruction (objects still alive).
    pub fn finish(self) {
        let log = self.log.clone();
        drop(self);
        assert!(
            !log.device_alive(),
            "a resource outlived the context (leak): the device was not destroyed"
        );
        let messages = log.take();
        assert!(
            messages.is_empty(),
            "{} validation message(s):\n{}",
            messages.len(),
            join(&messages)
        );
    }
}

impl Default for GpuTest {
    fn default() -> Self {
        GpuTest::new()
    }
}

fn join(messages: &[translucent::vk::ValidationMessage]) -> String {
    messages
        .iter()
        .map(|m| format!("  {m}"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Named tolerances of an 8-bit image comparison (differences in 0..=255 per channel).
#[derive(Clone, Copy, Debug)]
pub struct ImageTolerance {
    /// Largest allowed mean absolute difference over all channels of all pixels.
    pub mean_abs: f64,
    /// Percentile (0..=100) of per-pixel max-channel differences that must stay within `max_at_percentile`.
    pub percentile: f64,
    pub max_at_percentile: u8,
}

/// The outcome of [`compare_to_reference`].
#[derive(Clone, Copy, Debug)]
pub struct ImageDiff {
    pub mean_abs: f64,
    pub at_percentile: u8,
    pub max: u8,
}

/// Compares an 8-bit RGB image with the PNG at `reference`. On failure writes
/// `target/test-output/<name>-{actual,reference,difference}.png` and returns a message naming them.
/// With env `TRANSLUCENT_BLESS=1`, (re)writes the reference instead and passes.
pub fn compare_to_reference(
    name: &str,
    width: u32,
    height: u32,
    actual_rgb8: &[u8],
    reference: &Path,
    tolerance: ImageTolerance,
) -> Result<ImageDiff, String> {
    let actual = image::RgbImage::from_raw(width, height, actual_rgb8.to_vec())
        .ok_or("actual image has the wrong size")?;
    if std::env::var("TRANSLUCENT_BLESS").is_ok_and(|v| v == "1") {
        actual
            .save(reference)
            .map_err(|e| format!("blessing {}: {e}", reference.display()))?;
    }
    let out = test_output_dir();
    let write_actual = || {
        let path = out.join(format!("{name}-actual.png"));
        let _ = actual.save(&path);
        path
    };
    let expected = match image::open(reference) {
        Ok(img) => img.to_rgb8(),
        Err(e) => {
            let path = write_actual();
            return Err(format!(
                "cannot read reference {}: {e}; actual written to {}",
                reference.display(),
                path.display()
            ));
        }
    };
    if expected.dimensions() != actual.dimensions() {
        let path = write_actual();
        return Err(format!(
            "reference is {:?}, actual {:?}; actual written to {}",
            expected.dimensions(),
            actual.dimensions(),
            path.display()
        ));
    }
    let mut per_pixel: Vec<u8> = Vec::with_capacity((width * height) as usize);
    let mut sum = 0u64;
    let mut difference = image::RgbImage::new(width, height);
    for ((a, e), d) in actual
        .pixels()
        .zip(expected.pixels())
        .zip(difference.pixels_mut())
    {
        let diffs: [u8; 3] = std::array::from_fn(|c| a[c].abs_diff(e[c]));
        sum += diffs.iter().map(|&x| u64::from(x)).sum::<u64>();
        per_pixel.push(*diffs.iter().max().unwrap_or(&0));
        // Amplified so small differences are visible.
        *d = image::Rgb(diffs.map(|x| x.saturating_mul(8)));
    }
    per_pixel.sort_unstable();
    let rank = ((tolerance.percentile / 100.0) * (per_pixel.len() - 1) as f64).round() as usize;
    let diff = ImageDiff {
        mean_abs: sum as f64 / (3 * per_pixel.len()) as f64,
        at_percentile: per_pixel[rank.min(per_pixel.len() - 1)],
        max: *per_pixel.last().unwrap_or(&0),
    };
    if diff.mean_abs > tolerance.mean_abs || diff.at_percentile > tolerance.max_at_percentile {
        let actual_path = write_actual();
        let _ = expected.save(out.join(format!("{name}-reference.png")));
        let _ = difference.save(out.join(format!("{name}-difference.png")));
        return Err(format!(
            "{name}: {diff:?} exceeds {tolerance:?}; actual, reference and difference (x8) written next to {}",
            actual_path.display()
        ));
    }
    Ok(diff)
}

/// Largest per-channel difference between two renders of the same frame, relative to the
/// reference's brightest channel; asserts every pixel of both images is finite (no NaN or Inf
/// leaves the shading) and that the reference is not black (so the comparison can fail).
pub fn relative_difference(actual: &LinearImage, reference: &LinearImage) -> f32 {
    let peak = reference
        .pixels
        .iter()
        .flat_map(|p| p[..3].iter().copied())
        .fold(0.0f32, f32::max);
    assert!(peak > 0.0, "the reference is black");
    let mut worst = 0.0f32;
    for (a, r) in actual.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            assert!(a[c].is_finite() && r[c].is_finite(), "{a:?} {r:?}");
            worst = worst.max((a[c] - r[c]).abs() / peak);
        }
    }
    worst
}

/// The library's defaults before wave 6: the cascade, the boundary flux, no single scattering,
/// the classical D (`ObjectParams::default()` is now the real-time default: multigrid, the second-collision
/// source, the march). The skip, edit and gather tests were written for it: they count the
/// cascade's iterations per level, list the passes without the march, and deform (the
/// multigrid solves the rest pose only).
pub fn cascade_params() -> translucent::ObjectParams {
    use translucent::defaults::{Schedule, Settings};
    Settings {
        schedule: Schedule::Cascade,
        single_scattering: None,
        diffusion: translucent::material::DiffusionCoefficient::Classical,
        ..Settings::default()
    }
    .with_source(translucent::solver::transport::Source::BoundaryFlux)
    .object_params()
}

/// A QuadGraph object (the one frame composition) for `graph` with the solve `params`, every
/// other setting default (skips on, specular on).
pub fn quadgraph_object(
    ctx: &Context,
    graph: &translucent::QuadGraph,
    field: &translucent::material::MaterialField,
    scene: &translucent::scene::Scene,
    params: translucent::solver::gpu::GpuSolveParams,
) -> translucent::TranslucentObject {
    translucent::TranslucentObject::new(
        ctx,
        std::sync::Arc::new(graph.clone()),
        field,
        scene,
        &translucent::ObjectParams {
            solve: params,
            // why: the solve is the caller's; single scattering (on by default) is not.
            single_scattering: None,
            // why: the material's own D, as the f64 CPU solver the tests compare with reads it.
            diffusion: field.diffusion(),
            ..translucent::ObjectParams::default()
        },
    )
    .expect("object")
}

/// [`quadgraph_object`] whose cold solves iterate every level whatever the graph's size
/// (`single_level_nodes: 0`): the multi-level solve the solver tests' tolerances were set for.
pub fn multilevel_object(
    ctx: &Context,
    graph: &translucent::QuadGraph,
    field: &translucent::material::MaterialField,
    scene: &translucent::scene::Scene,
    params: translucent::solver::gpu::GpuSolveParams,
) -> translucent::TranslucentObject {
    translucent::TranslucentObject::new(
        ctx,
        std::sync::Arc::new(graph.clone()),
        field,
        scene,
        &translucent::ObjectParams {
            solve: params,
            single_level_nodes: 0,
            // why: the solve is the caller's; single scattering (on by default) is not.
            single_scattering: None,
            // why: the material's own D, as the f64 CPU solver the tests compare with reads it.
            diffusion: field.diffusion(),
            ..translucent::ObjectParams::default()
        },
    )
    .expect("object")
}

/// One frame of `object` into a fresh `width x height` headless host (waited, read back).
pub fn render_once(
    ctx: &Context,
    object: &mut translucent::TranslucentObject,
    width: u32,
    height: u32,
) -> (translucent::headless::Captured, translucent::FrameReport) {
    let mut host = translucent::headless::HeadlessHost::new(ctx, width, height).expect("host");
    host.render(ctx, object).expect("frame")
}

/// A procedural shape with lambert exitance (see `ExitanceMesh::procedural`) and the scene of
/// `lights` without environment: what the old `render::Scene::procedural` built in one value.
pub fn exitance_scene(
    shape: &str,
    size_mm: f64,
    lights: Vec<translucent::scene::Light>,
    eta: f64,
) -> (
    translucent::headless::ExitanceMesh,
    translucent::scene::Scene,
) {
    let mesh = translucent::headless::ExitanceMesh::procedural(shape, size_mm, &lights, eta)
        .expect("procedural mesh");
    (
        mesh,
        translucent::scene::Scene {
            lights,
            environment: translucent::scene::Environment::None,
        },
    )
}

/// One solve of `gpu` in its own waited submission, as the old `GpuDiffusion::record` recorded
/// it: the staged edits (material, deformation) if any, then the solve of every level (warm when
/// `warm` and a solution is held) and J+ into the surface nodes and the
/// bound display mesh, each a frame-graph pass. Returns the plan and the profiler's milliseconds
/// per scope (passes and their nested scopes: "diffusion jacobi", "edit deform", ...).
pub fn solve_once(
    ctx: &Context,
    gpu: &mut translucent::solver::gpu::GpuDiffusion,
    warm: bool,
) -> (
    translucent::solver::gpu::SolvePlan,
    std::collections::BTreeMap<String, f64>,
) {
    use translucent::frame::quadgraph::PASS_EDITS;
    use translucent::frame::FrameGraph;
    use translucent::solver::gpu::{PASS_EXITANCE, PASS_SOLVE};
    let edits = gpu.take_edits();
    let plan = gpu.plan(warm, false);
    let gpu = &*gpu;
    let mut profiler =
        translucent::vk::GpuProfiler::new(ctx, "test solve", 4096).expect("profiler");
    let mut result = Ok(());
    let submission = ctx
        .submit("test solve", |cb| {
            let (frame, _) = ctx.frames();
            let mut graph = FrameGraph::new(ctx);
            if let Some(edits) = &edits {
                graph
                    .pass(PASS_EDITS)
                    .uses(gpu.edit_uses(edits))
                    .record(move |p| {
                        // SAFETY: inside the pass declaring the edits' uses; `gpu` and `edits`
                        // outlive the waited submission.
                        unsafe { gpu.record_edits(p.ctx, p.cb, edits, p.profiler()) };
                        Ok(())
                    });
            }
            let plan = &plan;
            graph
                .pass(PASS_SOLVE)
                .uses(gpu.solve_uses(None))
                .record(move |p| {
                    // SAFETY: inside the pass declaring the solve's uses.
                    unsafe { gpu.record_solve(p.ctx, p.cb, plan, None, p.profiler()) };
                    Ok(())
                });
            graph
                .pass(PASS_EXITANCE)
                .uses(gpu.exitance_uses())
                .record(move |p| {
                    // SAFETY: inside the pass declaring the exitance's uses.
                    unsafe { gpu.record_exitance(p.ctx, p.cb, p.profiler()) };
                    Ok(())
                });
            // SAFETY: `cb` is recording outside a rendering scope; everything outlives the wait.
            unsafe {
                profiler.begin_frame(cb, frame);
                result = graph.execute(cb, Some(&mut profiler), false).map(|_| ());
            }
            Ok(())
        })
        .expect("submit solve");
    let frame = submission.frame();
    submission.wait().expect("wait solve");
    result.expect("solve graph");
    drop(edits);
    profiler.frame_completed(frame);
    let passes = profiler
        .latest()
        .filter(|t| t.frame == frame)
        .map(|t| t.passes())
        .unwrap_or_default();
    (plan, passes)
}

/// Named tolerances shared by the GPU tests, each with its reason.
pub mod tol {
    /// GPU J+ or phi (mixed or fp32 state) against the f64 exact discrete solve of the same graph,
    /// relative RMS: the GPU stops at a 1e-4 convergence estimate and gathers q in fp16 (~5e-4),
    /// so a few 1e-3 remain.
    pub const GPU_VS_EXACT: f64 = 5e-3;
    /// The same for fp16 state: ~1e-3 relative rounding per Jacobi step accumulates over tens of
    /// iterations.
    pub const GPU_FP16_VS_EXACT: f64 = 2e-2;
}

/// Per level of `graph`, the boundary flux q of `scene` as the GPU solve uploads it (f32), with the
/// environment's diffuse transmittance of `exit`'s boundary.
pub fn level_irradiance(
    graph: &translucent::QuadGraph,
    field: &translucent::material::MaterialField,
    scene: &translucent::scene::Scene,
    exit: translucent::solver::transport::ExitQuery,
) -> Vec<Vec<[f32; 3]>> {
    let t_env =
        translucent::solver::transport::Boundary::new(field.eta(), exit).diffuse_transmittance();
    graph
        .levels
        .iter()
        .map(|l| {
            scene
                .surface_irradiance_with(l, field.eta(), None, t_env)
                .iter()
                .map(|q| q.map(|v| v as f32))
                .collect()
        })
        .collect()
}

/// The multigrid tests' hard material: sigma_s' 0.1 and 1000 /mm (kappa 1e4 apart) across a
/// plane, no absorption anywhere, eta 1.3.
pub fn kappa_contrast_field() -> translucent::material::MaterialField {
    use translucent::material::{Coefficients, MaterialField, Procedural};
    let c = |s: f64| Coefficients::new([s; 3], [0.0; 3]).expect("valid coefficients");
    MaterialField::procedural(
        Procedural::Split {
            normal: glam::DVec3::new(1.0, 0.3, 0.1).normalize(),
            offset: 0.0,
            below: c(0.1),
            above: c(1000.0),
        },
        1.3,
    )
    .expect("a valid split field")
}
