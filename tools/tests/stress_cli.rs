//! The numerical stress matrix end to end through `translucent render` (issue 6, DESIGN section
//! 9), CI-sized: NaN, Inf and out-of-range values in every input exit non-zero with a message
//! naming the option or file and write no output file; extreme but valid scenes (1 mm and 10 m
//! objects, light 1e-4 and 1e4, sigma_a = 0 and 1e4 sigma_s') write an EXR whose every pixel is
//! finite and a JSON report with no `null` (serde_json's NaN/Inf) in it, on the CPU and GPU
//! solvers. Validation is on: any message fails a command.

mod common;

use std::path::Path;
use std::process::Output;

use common::{json_of, rgb, scratch, translucent};

fn render(dir: &Path, out: &Path, solver: &str, extra: &[&str]) -> Output {
    let out = out.to_str().expect("utf-8 path");
    let mut args = vec![
        "render",
        "--resolution",
        "8",
        "--levels",
        "1",
        "--width",
        "16",
        "--height",
        "16",
        "--json",
        "--solver",
        solver,
        "--out",
        out,
    ];
    if !extra.contains(&"--mesh") {
        args.extend(["--shape", "sphere"]);
    }
    if !extra.contains(&"--size-mm") {
        args.extend(["--size-mm", "20"]);
    }
    args.extend(extra);
    translucent(&args, dir)
}

/// Every pixel of a linear EXR (r, g, b).
fn exr_pixels(path: &Path) -> Vec<[f32; 3]> {
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| vec![[0.0f32; 3]; res.width() * res.height()],
        |buf: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let w = (buf.len() as f64).sqrt() as usize; // 16 x 16
            buf[pos.y() * w + pos.x()] = [r, g, b];
        },
    )
    .expect("read the EXR");
    image.layer_data.channel_data.pixels
}

#[test]
fn non_finite_and_out_of_range_inputs_exit_with_a_message_and_write_nothing() {
    let dir = scratch("stress-bad");
    let obj = dir.join("nan.obj");
    std::fs::write(
        &obj,
        "v 0 0 0\nv 1 0 0\nv 0 nan 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    // A 2x2x2 .vol grid whose last value is NaN (header: VOL 3, encoding 1, res, channels, bbox).
    let vol = dir.join("nan.vol");
    let mut bytes = b"VOL\x03".to_vec();
    for v in [1i32, 2, 2, 2, 6] {
        bytes.extend(v.to_le_bytes());
    }
    for v in [-30f32, -30.0, -30.0, 30.0, 30.0, 30.0] {
        bytes.extend(v.to_le_bytes());
    }
    for i in 0..48 {
        let v = if i == 47 { f32::NAN } else { 1.0f32 };
        bytes.extend(v.to_le_bytes());
    }
    std::fs::write(&vol, bytes).unwrap();
    let (obj, vol) = (obj.to_str().unwrap(), vol.to_str().unwrap());
    let cases: &[(&[&str], &str)] = &[
        (&["--sigma-a", "nan,0,0", "--sigma-s", "1,1,1"], "sigma_a"),
        (&["--sigma-a", "0,0,0", "--sigma-s", "inf,1,1"], "sigma_s'"),
        (&["--sigma-a", "0,0,0", "--sigma-s", "0,1,1"], "sigma_t'"),
        (&["--eta", "nan"], "eta"),
        (&["--light", "dir:0,-1,0:nan,1,1"], "--light"),
        (&["--light", "dir:inf,-1,0:1,1,1"], "--light"),
        (&["--light", "point:nan,0,0:1,1,1"], "--light"),
        (
            &["--light", "dir:0,-1,0:1e300,1e300,1e300"],
            "above the supported",
        ),
        (&["--camera", "nan,0,0:0,0,0:40"], "--camera"),
        (&["--camera", "0,0,1e300:0,0,0:40"], "--camera"),
        (&["--env-constant", "nan,1,1"], "environment"),
        (&["--env-constant", "inf,1,1"], "environment"),
        (&["--size-mm", "nan"], "--size-mm"),
        (&["--size-mm", "inf"], "--size-mm"),
        (&["--size-mm", "1e300"], "--size-mm"),
        (&["--size-mm", "1e-300"], "--size-mm"),
        (&["--mesh", obj], "non-finite"),
        (&["--volume", vol], "NaN"),
    ];
    let out = dir.join("out.exr");
    for (extra, names) in cases {
        for solver in ["cpu", "gpu"] {
            let run = render(&dir, &out, solver, extra);
            let stderr = String::from_utf8_lossy(&run.stderr);
            assert!(!run.status.success(), "{extra:?} {solver}: accepted");
            assert!(
                stderr.contains(names),
                "{extra:?} {solver}: the message does not name {names:?}: {stderr}"
            );
            assert!(
                !out.exists(),
                "{extra:?} {solver}: an output file was written"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn extreme_valid_scenes_write_finite_images_and_reports() {
    let dir = scratch("stress-good");
    let out = dir.join("out.exr");
    let cases: &[&[&str]] = &[
        &["--size-mm", "1"],
        &["--size-mm", "10000"],
        &["--light", "dir:0,-1,0:1e-4,1e-4,1e-4"],
        &["--light", "dir:0,-1,0:1e4,1e4,1e4"],
        &["--sigma-a", "0,0,0", "--sigma-s", "1,1,1"],
        &["--sigma-a", "1e4,1e4,1e4", "--sigma-s", "1,1,1"],
    ];
    for extra in cases {
        for solver in ["cpu", "gpu"] {
            let _ = std::fs::remove_file(&out);
            let run = render(&dir, &out, solver, extra);
            let json = json_of(&run);
            let text = String::from_utf8_lossy(&run.stdout);
            for key in ["residual", "energy", "clamped_nodes", "levels", "frames"] {
                let value = json[key].to_string();
                assert!(
                    !value.contains("null"),
                    "{extra:?} {solver}: NaN/Inf in {key}: {text}"
                );
            }
            let energy = &json["energy"];
            let (input, exitance) = (rgb(&energy["transmitted_input"]), rgb(&energy["exitance"]));
            assert!(input.iter().chain(&exitance).all(|v| v.is_finite()));
            let pixels = exr_pixels(&out);
            assert_eq!(pixels.len(), 256);
            assert!(
                pixels.iter().flatten().all(|v| v.is_finite() && *v >= 0.0),
                "{extra:?} {solver}: NaN, Inf or negative pixels"
            );
            assert!(
                pixels.iter().flatten().any(|&v| v > 0.0),
                "{extra:?} {solver}: a black image"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
