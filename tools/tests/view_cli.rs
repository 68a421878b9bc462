//! `translucent view` under Xvfb: a scripted session (orbit, light, material key, zoom, a resize
//! and back) runs with validation and synchronization validation on, exits 0, its screenshot
//! matches `translucent render` of the same final scene (the viewer's report prints it as
//! render options), and frames with nothing changed record only the shading pass.
//!
//! Needs `Xvfb` (tools/setup.sh installs it): with `CI` set a missing Xvfb fails the test,
//! without it the test says it is skipped.

mod common;

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

use common::{scratch, translucent};

/// The viewer's screenshot against `render`'s EXR of the same scene, relative RMS over the whole
/// image: the viewer warm-starts its solves after each change and render solves cold, both to
/// the same 1e-4 estimated error per level; measured 2.0e-4 on this scene (lavapipe). A wrong
/// camera, light or material gives 1e-1 and more.
const SCREENSHOT_RELATIVE_RMS: f64 = 2e-3;
/// The PNGs (8-bit sRGB after the same tone map): mean absolute difference in 8-bit steps.
/// Measured 0.003.
const SCREENSHOT_PNG_MEAN_STEPS: f64 = 0.5;

/// A virtual X server for the test, stopped when dropped.
struct Xvfb {
    child: Child,
    display: String,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts Xvfb on a free display (`-displayfd` prints the one it took), or `None` when it is not
/// installed and `CI` is not set.
fn start_xvfb() -> Option<Xvfb> {
    let started = Command::new("Xvfb")
        .args([
            "-displayfd",
            "1",
            "-screen",
            "0",
            "640x480x24",
            "-nolisten",
            "tcp",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn();
    let mut child = match started {
        Ok(c) => c,
        Err(e) => {
            assert!(
                std::env::var_os("CI").is_none(),
                "Xvfb is needed for the viewer test under CI ({e}): run tools/setup.sh (apt-get install xvfb)"
            );
            eprintln!("skipped: Xvfb is not installed ({e}); tools/setup.sh installs it");
            return None;
        }
    };
    let mut line = String::new();
    let stdout = child.stdout.take().expect("piped stdout");
    BufReader::new(stdout)
        .read_line(&mut line)
        .expect("Xvfb prints its display number");
    let number = line.trim();
    assert!(
        !number.is_empty() && number.chars().all(|c| c.is_ascii_digit()),
        "Xvfb did not start (display {line:?})"
    );
    Some(Xvfb {
        child,
        display: format!(":{number}"),
    })
}

/// Linear RGB of an EXR, row-major.
fn read_exr(path: &Path) -> (usize, usize, Vec<[f32; 3]>) {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| {
            (
                res.width(),
                res.height(),
                vec![[0.0f32; 3]; res.width() * res.height()],
            )
        },
        |(w, _, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = [r, g, b]
        },
    )
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    image.layer_data.channel_data.pixels
}

/// Relative RMS of `ours` against `theirs` over all pixels and channels; `theirs` must not be
/// black (`what` says what it is).
fn relative_rms(ours: &[[f32; 3]], theirs: &[[f32; 3]], what: &str) -> f64 {
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for (a, b) in ours.iter().zip(theirs) {
        for c in 0..3 {
            diff += f64::from(a[c] - b[c]).powi(2);
            norm += f64::from(b[c]).powi(2);
        }
    }
    assert!(norm > 0.0, "{what}");
    (diff / norm).sqrt()
}

/// The small sphere of the 96 x 72 viewer tests (a 16-cell two-level bake).
const SMALL_SPHERE: [&str; 12] = [
    "--shape",
    "sphere",
    "--size-mm",
    "20",
    "--resolution",
    "16",
    "--levels",
    "2",
    "--width",
    "96",
    "--height",
    "72",
];

/// The viewer's `--report` written to `dir/report.json`.
fn read_report(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("report.json")).expect("report"))
        .expect("report is JSON")
}

fn view(display: &str, dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_translucent"))
        .arg("view")
        .args(args)
        .env("DISPLAY", display)
        .env_remove("WAYLAND_DISPLAY")
        .env("TRANSLUCENT_VALIDATION", "1")
        .env("TRANSLUCENT_DEVICE", "llvmpipe")
        .env("TRANSLUCENT_CACHE_DIR", dir)
        // The cache's limit: one byte, so the bake the viewer uses is all it keeps.
        .env("TRANSLUCENT_CACHE_LIMIT", "1")
        .current_dir(dir)
        .output()
        .expect("run translucent view")
}

const SCRIPT: &str = "\
# the first frame solves cold; then one change at a time, each followed by quiet frames
orbit -35 12
wait 2
light 40 -10          # the key light: a warm-started solve
wait 2
key 2                 # marble: a new material, warm-started, shadows kept
wait 2
zoom 0.85             # camera only: shading only
wait 2
resize 200 150        # the swapchain is rebuilt
wait 3
resize 160 120
";

/// As the "must show": a 120-frame scripted session (the quiet frames after the script's
/// last change are shading-only and cheap).
const FRAMES: &str = "120";

#[test]
fn a_scripted_session_under_xvfb_matches_render_and_quiet_frames_only_shade() {
    let Some(xvfb) = start_xvfb() else { return };
    let dir = scratch("view");
    std::fs::write(dir.join("demo.script"), SCRIPT).expect("script");
    // An earlier bake in the cache, least recently used: evicted by the limit.
    std::fs::write(dir.join("earlier.qgraph"), [0u8; 64]).expect("old bake");
    let scene = [
        "--shape",
        "sphere",
        "--size-mm",
        "20",
        "--resolution",
        "16",
        "--levels",
        "2",
        "--width",
        "160",
        "--height",
        "120",
    ];
    let mut args: Vec<&str> = scene.to_vec();
    args.extend([
        "--frames",
        FRAMES,
        "--script",
        "demo.script",
        "--screenshot",
        "shot.png",
        "--report",
        "report.json",
        // why: this session checks the cascade's skips and warm starts level by level (the
        // report's iterations per level); the march (on by default) is view-dependent and re-runs
        // on every camera move (its own skips: tests/tests/single_scattering.rs). The default
        // view (multigrid, the march): `the_default_view_names_its_settings_and_matches_render`.
        "--schedule",
        "cascade",
        "--single-scattering",
        "off",
    ]);
    let out = view(&xvfb.display, &dir, &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}\n{stderr}", out.status);
    assert!(!stderr.contains("validation"), "{stderr}");
    assert!(
        !dir.join("earlier.qgraph").exists(),
        "not evicted: {stderr}"
    );
    let bakes = std::fs::read_dir(&dir)
        .expect("dir")
        .filter(|e| {
            e.as_ref()
                .is_ok_and(|e| e.file_name().to_string_lossy().ends_with(".qgraph"))
        })
        .count();
    assert_eq!(bakes, 1, "the viewer's own bake stays");

    let report = read_report(&dir);
    assert_eq!(report["validation_messages"], 0);
    let frames = report["frames"].as_array().expect("frames");
    assert_eq!(
        frames.len(),
        FRAMES.parse::<usize>().expect("count"),
        "one entry per frame"
    );
    let passes = |f: &serde_json::Value| -> Vec<String> {
        f["passes"]
            .as_array()
            .expect("passes")
            .iter()
            .map(|p| p.as_str().expect("name").to_string())
            .collect()
    };
    // Frame 0: a cold solve whose iterations came back (the tangential flux's gradient of the
    // new exitance: render's default for a homogeneous material).
    assert_eq!(
        passes(&frames[0]),
        [
            "shadow_map",
            "gather_q",
            "diffusion",
            "exitance",
            "tangential gradient",
            "shading"
        ]
    );
    assert!(frames[0]["iterations"]
        .as_array()
        .is_some_and(|i| i.iter().all(|n| n.as_u64().is_some_and(|n| n > 0))));
    // The light change (frame 2): a warm start.
    assert!(passes(&frames[2]).contains(&"diffusion".to_string()));
    assert_eq!(frames[2]["skipped"]["diffusion init"], "warm start");
    // The material key (frame 4): gather and solve again, the shadow maps kept.
    assert_eq!(
        passes(&frames[4]),
        [
            "gather_q",
            "diffusion",
            "exitance",
            "tangential gradient",
            "shading"
        ]
    );
    assert_eq!(
        frames[4]["skipped"]["shadow_map"],
        "lights and shape unchanged"
    );
    // The zoom (frame 6): shading only, because only the camera moved.
    assert_eq!(passes(&frames[6]), ["shading"]);
    assert_eq!(frames[6]["skipped"]["diffusion"], "camera only");
    // The resize went through a rebuilt swapchain and back.
    assert!(frames
        .iter()
        .any(|f| f["extent"] == serde_json::json!([200, 150])));
    // Quiet frames (nothing changed): the shading pass alone, each other pass skipped and why.
    let last = frames.last().expect("a frame");
    assert_eq!(last["extent"], serde_json::json!([160, 120]));
    assert_eq!(passes(last), ["shading"]);
    for pass in ["shadow_map", "gather_q", "diffusion", "exitance"] {
        assert_eq!(last["skipped"][pass], "nothing changed", "{pass}");
    }
    assert!(
        last["gpu_ms"]
            .as_array()
            .is_some_and(|t| t.iter().any(|s| s[0] == "shading")),
        "the overlay's timings: {last}"
    );
    assert_eq!(report["final"]["material"], "marble");

    // The same final scene through `translucent render`.
    let render_args: Vec<String> = report["final"]["render_args"]
        .as_array()
        .expect("render_args")
        .iter()
        .map(|a| a.as_str().expect("text").to_string())
        .collect();
    let reference = dir.join("render.exr");
    let reference_png = dir.join("render.png");
    for out_file in [&reference, &reference_png] {
        let mut args: Vec<&str> = vec!["render"];
        args.extend(render_args.iter().map(String::as_str));
        let out = format!("--out={}", out_file.display());
        args.push(&out);
        let rendered = translucent(&args, &dir);
        assert!(
            rendered.status.success(),
            "render {args:?}: {}",
            String::from_utf8_lossy(&rendered.stderr)
        );
    }
    let (w, h, ours) = read_exr(&dir.join("shot.exr"));
    let (rw, rh, theirs) = read_exr(&reference);
    assert_eq!((w, h), (rw, rh));
    assert_eq!((w, h), (160, 120));
    let rms = relative_rms(&ours, &theirs, "the reference is black");
    eprintln!("viewer screenshot against render: relative RMS {rms:.2e}");
    assert!(
        rms <= SCREENSHOT_RELATIVE_RMS,
        "relative RMS {rms} > {SCREENSHOT_RELATIVE_RMS}"
    );
    let png = |p: PathBuf| image::open(&p).expect("png").to_rgb8();
    let (a, b) = (png(dir.join("shot.png")), png(reference_png));
    assert_eq!(a.dimensions(), b.dimensions());
    let mean_steps = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| f64::from(x.abs_diff(*y)))
        .sum::<f64>()
        / a.as_raw().len() as f64;
    eprintln!("PNG mean difference {mean_steps:.3} steps");
    assert!(mean_steps <= SCREENSHOT_PNG_MEAN_STEPS, "{mean_steps}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_view_options_fail_before_the_window_opens() {
    let dir = scratch("view-bad");
    std::fs::write(dir.join("bad.script"), "orbit 10 0\nfly 3\n").expect("script");
    // No DISPLAY: each of these must fail on the option, not on the missing window system.
    for (args, needle) in [
        (vec!["--frames", "0"], "--frames 0"),
        (vec!["--screenshot", "x.jpg"], "must end in .png or .exr"),
        (
            vec!["--script", "bad.script"],
            "bad.script:2: unknown command \"fly\"",
        ),
        (vec!["--script", "missing.script"], "missing.script"),
        (vec!["--resolution", "fine"], "--resolution"),
        (vec!["--tolerance", "nan"], "--tolerance"),
        (
            vec!["--shader-dir", "no-such-dir"],
            "--shader-dir: shader source no-such-dir: not a directory",
        ),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_translucent"))
            .arg("view")
            .args(&args)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .env("TRANSLUCENT_CACHE_DIR", &dir)
            .current_dir(&dir)
            .output()
            .expect("run");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
        assert_eq!(
            stderr.lines().filter(|l| l.starts_with("error")).count(),
            1,
            "one error line: {stderr}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The method key builds the voxel method in the window (issue 16: "method (quadgraph/voxel/dipole
/// as they land)"): the screenshot after `method voxel` matches `translucent render --method
/// voxel` of the same scene, validation silent.
#[test]
fn the_method_key_switches_to_voxel_and_matches_render() {
    let Some(xvfb) = start_xvfb() else { return };
    let dir = scratch("view-voxel");
    std::fs::write(dir.join("voxel.script"), "method voxel\nwait 3\n").expect("script");
    let out = view(
        &xvfb.display,
        &dir,
        &[
            SMALL_SPHERE.as_slice(),
            &[
                "--frames",
                "4",
                "--script",
                "voxel.script",
                "--screenshot",
                "shot.png",
                "--report",
                "report.json",
            ],
        ]
        .concat(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}\n{stderr}", out.status);
    let report = read_report(&dir);
    assert_eq!(report["validation_messages"], 0);
    let render_args: Vec<String> = report["final"]["render_args"]
        .as_array()
        .expect("render_args")
        .iter()
        .map(|a| a.as_str().expect("text").to_string())
        .collect();
    assert!(
        render_args.iter().any(|a| a == "--method=voxel"),
        "{render_args:?}"
    );
    let reference = dir.join("render.exr");
    let mut args: Vec<&str> = vec!["render"];
    args.extend(render_args.iter().map(String::as_str));
    let out_arg = format!("--out={}", reference.display());
    args.push(&out_arg);
    let rendered = translucent(&args, &dir);
    assert!(
        rendered.status.success(),
        "render {args:?}: {}",
        String::from_utf8_lossy(&rendered.stderr)
    );
    let (_, _, ours) = read_exr(&dir.join("shot.exr"));
    let (_, _, theirs) = read_exr(&reference);
    let rms = relative_rms(&ours, &theirs, "the voxel render is black");
    eprintln!("voxel screenshot against render: relative RMS {rms:.2e}");
    assert!(rms <= SCREENSHOT_RELATIVE_RMS, "relative RMS {rms}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The viewer at its defaults (no solver option) runs the library's real-time defaults, and its
/// report's equivalent render command names them and reproduces its frame (issue 13: one place
/// for defaults).
#[test]
fn the_default_view_names_its_settings_and_matches_render() {
    let Some(xvfb) = start_xvfb() else { return };
    let dir = scratch("view-defaults");
    let out = view(
        &xvfb.display,
        &dir,
        &[
            SMALL_SPHERE.as_slice(),
            &[
                "--frames",
                "3",
                "--screenshot",
                "shot.png",
                "--report",
                "report.json",
            ],
        ]
        .concat(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "exit {:?}\n{stderr}", out.status);
    let report = read_report(&dir);
    assert_eq!(report["validation_messages"], 0);
    let render_args: Vec<String> = report["final"]["render_args"]
        .as_array()
        .expect("render_args")
        .iter()
        .map(|a| a.as_str().expect("text").to_string())
        .collect();
    // The library's defaults for a homogeneous material, named.
    for named in [
        "--schedule=multigrid",
        "--source=second",
        "--single-scattering=on",
        "--precision=mixed",
        "--supersample=1",
    ] {
        assert!(
            render_args.iter().any(|a| a == named),
            "{named}: {render_args:?}"
        );
    }
    assert!(
        !render_args.iter().any(|a| a.starts_with("--iterations")),
        "the multigrid takes no cap: {render_args:?}"
    );
    let first = &report["frames"][0];
    assert!(
        first["passes"]
            .as_array()
            .is_some_and(|p| p.iter().any(|p| p == "single_scattering")),
        "single scattering runs by default: {first}"
    );
    let reference = dir.join("render.exr");
    let mut args: Vec<&str> = vec!["render"];
    args.extend(render_args.iter().map(String::as_str));
    let out_arg = format!("--out={}", reference.display());
    args.push(&out_arg);
    let rendered = translucent(&args, &dir);
    let render_stderr = String::from_utf8_lossy(&rendered.stderr);
    assert!(
        rendered.status.success(),
        "render {args:?}: {render_stderr}"
    );
    let (_, _, ours) = read_exr(&dir.join("shot.exr"));
    let (_, _, theirs) = read_exr(&reference);
    let rms = relative_rms(&ours, &theirs, "the render is black");
    eprintln!("default view against its render command: relative RMS {rms:.2e}");
    assert!(rms <= SCREENSHOT_RELATIVE_RMS, "relative RMS {rms}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Copies `from` into `to` recursively.
fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("mkdir");
    for entry in std::fs::read_dir(from)
        .expect("read_dir")
        .filter_map(Result::ok)
    {
        let (src, dst) = (entry.path(), to.join(entry.file_name()));
        if src.is_dir() {
            copy_tree(&src, &dst);
        } else {
            std::fs::copy(&src, &dst).expect("copy");
        }
    }
}

/// The line of `mesh/shade_mesh.frag` that writes the pixel.
const SHADE_OUTPUT: &str = "out_radiance = vec4(radiance, 1.0);";

/// The screenshot after a hot reload against the one before it, relative RMS: both frames come
/// from a cold solve of the same scene to the same tolerance (the reload rebuilds the object),
/// so only the edit should differ; the edit below halves the radiance (relative RMS 1.0 when
/// the reload did nothing). Measured: 0 (lavapipe).
const RELOAD_RELATIVE_RMS: f64 = 2e-3;

/// Runs a 5-frame session on a copy of shaders-glsl/ edited by `edit`: a screenshot after
/// frame 1, `reload-shaders` in frame 2, the final screenshot after frame 4. Returns the report
/// and the relative RMS of `after - scale * before` against `scale * before`.
fn reload_session(
    xvfb: &Xvfb,
    name: &str,
    edit: impl Fn(&Path),
    scale: f32,
) -> (serde_json::Value, f64, String) {
    let dir = scratch(name);
    let shaders = dir.join("shaders");
    copy_tree(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders-glsl"),
        &shaders,
    );
    edit(&shaders);
    std::fs::write(
        dir.join("reload.script"),
        "wait 1\nscreenshot before.png\nwait 1\nreload-shaders\n",
    )
    .expect("script");
    let out = view(
        &xvfb.display,
        &dir,
        &[
            SMALL_SPHERE.as_slice(),
            &[
                "--frames",
                "5",
                "--script",
                "reload.script",
                "--shader-dir",
                "shaders",
                "--screenshot",
                "after.png",
                "--report",
                "report.json",
            ],
        ]
        .concat(),
    );
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "exit {:?}\n{stderr}", out.status);
    assert!(!stderr.contains("validation"), "{stderr}");
    let report = read_report(&dir);
    assert_eq!(report["validation_messages"], 0, "{stderr}");
    let (_, _, before) = read_exr(&dir.join("before.exr"));
    let (_, _, after) = read_exr(&dir.join("after.exr"));
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for (a, b) in after.iter().zip(&before) {
        for c in 0..3 {
            diff += f64::from(a[c] - scale * b[c]).powi(2);
            norm += f64::from(scale * b[c]).powi(2);
        }
    }
    assert!(norm > 0.0, "the first screenshot is black");
    let _ = std::fs::remove_dir_all(&dir);
    (report, (diff / norm).sqrt(), stderr)
}

/// Shader hot reload (issue 16): the viewer pointed at a copy of shaders-glsl/ with the shading
/// pass's fragment shader edited (radiance halved) and the present shader touched: after
/// `reload-shaders` the screenshot is half the one before, both pipelines were rebuilt, and
/// validation stayed silent.
#[test]
fn hot_reload_uses_an_edited_shader_from_the_shader_directory() {
    let Some(xvfb) = start_xvfb() else { return };
    let (report, rms, stderr) = reload_session(
        &xvfb,
        "view-reload",
        |shaders| {
            let frag = shaders.join("mesh/shade_mesh.frag");
            let text = std::fs::read_to_string(&frag).expect("read");
            assert!(
                text.contains(SHADE_OUTPUT),
                "the shader's output line moved"
            );
            let edited = text.replace(SHADE_OUTPUT, "out_radiance = vec4(0.5 * radiance, 1.0);");
            std::fs::write(&frag, edited).expect("write");
            let present = shaders.join("viewer/present.frag");
            let text = std::fs::read_to_string(&present).expect("read");
            std::fs::write(&present, format!("{text}\n// touched\n")).expect("write");
        },
        0.5,
    );
    let reloads = report["shader_reloads"].as_array().expect("shader_reloads");
    assert_eq!(reloads.len(), 1, "{stderr}");
    let reload = &reloads[0];
    assert_eq!(reload["ok"], true, "{reload}");
    assert_eq!(reload["frame"], 2);
    assert_eq!(
        reload["changed"],
        serde_json::json!(["mesh/shade_mesh.frag", "viewer/present.frag"])
    );
    assert_eq!(reload["compiled"], 2);
    eprintln!(
        "hot reload: compile {:.0} ms, total {:.0} ms; after/before relative RMS against 0.5: {rms:.2e}",
        reload["compile_ms"].as_f64().unwrap_or(f64::NAN),
        reload["reload_ms"].as_f64().unwrap_or(f64::NAN)
    );
    assert!(rms <= RELOAD_RELATIVE_RMS, "relative RMS {rms}\n{stderr}");
}

/// A broken shader in the shader directory: the reload reports glslc's error with the file and
/// line (report and stderr, which the overlay's note repeats), the old pipelines keep drawing
/// the same image, validation stays silent.
#[test]
fn hot_reload_of_a_broken_shader_keeps_the_old_pipeline_and_reports_the_line() {
    let Some(xvfb) = start_xvfb() else { return };
    let (report, rms, stderr) = reload_session(
        &xvfb,
        "view-reload-broken",
        |shaders| {
            let frag = shaders.join("mesh/shade_mesh.frag");
            let text = std::fs::read_to_string(&frag).expect("read");
            let mut lines: Vec<&str> = text.lines().collect();
            lines.insert(2, "this is not glsl;");
            std::fs::write(&frag, lines.join("\n")).expect("write");
        },
        1.0,
    );
    let reloads = report["shader_reloads"].as_array().expect("shader_reloads");
    assert_eq!(reloads.len(), 1, "{stderr}");
    let reload = &reloads[0];
    assert_eq!(reload["ok"], false, "{reload}");
    let message = reload["message"].as_str().expect("message");
    assert!(message.contains("old shaders kept"), "{message}");
    assert!(message.contains("shade_mesh.frag:3:"), "{message}");
    assert!(stderr.contains("shade_mesh.frag:3:"), "{stderr}");
    assert!(rms <= RELOAD_RELATIVE_RMS, "relative RMS {rms}\n{stderr}");
}

/// The README's hot-reload command runs as written (readme_commands.rs skips `view` commands:
/// they need a window), with a script, a frame count and CI sizes added: after the README's
/// `cp -r shaders-glsl my-shaders` and an edit, `reload-shaders` uses the edited shader.
#[test]
fn the_readme_hot_reload_command_runs_as_written() {
    let Some(xvfb) = start_xvfb() else { return };
    let readme = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../README.md"))
        .expect("README.md");
    let command = readme
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("translucent view") && l.contains("--shader-dir my-shaders"))
        .expect("the README's hot-reload command");
    let readme_args: Vec<&str> = command
        .split(" #")
        .next()
        .unwrap_or(command)
        .split_whitespace()
        .skip(2)
        .collect();
    let dir = scratch("view-reload-readme");
    let shaders = dir.join("my-shaders");
    copy_tree(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders-glsl"),
        &shaders,
    );
    let frag = shaders.join("mesh/shade_mesh.frag");
    let text = std::fs::read_to_string(&frag).expect("read");
    std::fs::write(
        &frag,
        text.replace(SHADE_OUTPUT, "out_radiance = vec4(0.5 * radiance, 1.0);"),
    )
    .expect("write");
    std::fs::write(dir.join("r.script"), "wait 1\nreload-shaders\n").expect("script");
    let mut args = readme_args;
    args.extend([
        "--resolution",
        "16",
        "--levels",
        "2",
        "--width",
        "96",
        "--height",
        "72",
        "--frames",
        "2",
        "--script",
        "r.script",
        "--report",
        "report.json",
    ]);
    let out = view(&xvfb.display, &dir, &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "{args:?}: exit {:?}\n{stderr}",
        out.status
    );
    let report = read_report(&dir);
    assert_eq!(report["validation_messages"], 0, "{stderr}");
    assert_eq!(report["shader_reloads"][0]["ok"], true, "{stderr}");
    assert_eq!(
        report["shader_reloads"][0]["changed"],
        serde_json::json!(["mesh/shade_mesh.frag"])
    );
    let _ = std::fs::remove_dir_all(&dir);
}
