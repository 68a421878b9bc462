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
