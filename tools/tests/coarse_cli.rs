//! `translucent render --coarse-operator / --coarse-storage / --coarse-drop` (issue 13): the JSON
//! names what ran, the multigrid's bytes by buffer add up to its part of `gpu_bytes_split`, fp16
//! coarse entries (the default) take fewer bytes than f32 for the same cycles, and the options are
//! refused without the multigrid schedule.

mod common;

use std::path::Path;

use common::{json_of, scratch, translucent};

/// Bytes per node are printed as floats: their sum matches the part to rounding.
const BYTES_ROUNDING: f64 = 1e-6;

fn render(dir: &Path, extra: &[&str]) -> std::process::Output {
    let out = dir.join("x.png");
    let mut args = vec![
        "render",
        "--out",
        out.to_str().expect("path"),
        "--json",
        "--width",
        "48",
        "--height",
        "48",
        "--resolution",
        "16",
        "--levels",
        "3",
        "--supersample",
        "1",
        "--single-scattering",
        "off",
    ];
    args.extend_from_slice(extra);
    translucent(&args, dir)
}

fn multigrid_per_node(json: &serde_json::Value) -> f64 {
    json["gpu_bytes_split"]["bytes_per_finest_node"]["multigrid"]
        .as_f64()
        .expect("multigrid bytes")
}

#[test]
fn coarse_options_are_reported_and_fp16_entries_take_fewer_bytes() {
    let dir = scratch("coarse");
    let f16 = json_of(&render(&dir, &[]));
    let f32 = json_of(&render(&dir, &["--coarse-storage", "f32"]));
    let re = json_of(&render(&dir, &["--coarse-operator", "rediscretized"]));
    assert_eq!(f16["coarse_operator"], "galerkin", "{f16}");
    assert_eq!(f16["coarse_storage"], "f16", "the default");
    assert_eq!(f32["coarse_storage"], "f32");
    assert_eq!(re["coarse_operator"], "rediscretized");
    for json in [&f16, &f32, &re] {
        assert_eq!(json["multigrid"]["state"], "Converged", "{json}");
        let by_buffer = json["gpu_bytes_split"]["multigrid_per_node_by_buffer"]
            .as_object()
            .expect("by buffer");
        let sum: f64 = by_buffer.values().map(|v| v.as_f64().expect("bytes")).sum();
        let part = multigrid_per_node(json);
        assert!(
            (sum - part).abs() <= BYTES_ROUNDING * part,
            "buffers {sum} against the multigrid's {part}"
        );
    }
    assert_eq!(
        f16["multigrid"]["cycles"], f32["multigrid"]["cycles"],
        "fp16 coarse entries only perturb the preconditioner"
    );
    assert!(multigrid_per_node(&f16) < multigrid_per_node(&f32));
    assert!(multigrid_per_node(&re) < multigrid_per_node(&f16));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--link-storage` and `--vector-storage` (benches/RESULTS.md "Multigrid storage (wave 7)"):
/// named in the JSON; the defaults (f32 links, RGB vectors) smaller than RGBA vectors for the
/// same cycles, packed links smaller still (the mixed interpolation's weights quantized).
#[test]
fn storage_options_are_reported_and_the_defaults_take_fewer_bytes() {
    let dir = scratch("storage");
    let default = json_of(&render(&dir, &[]));
    let wide = json_of(&render(&dir, &["--vector-storage", "rgba"]));
    let packed = json_of(&render(&dir, &["--link-storage", "packed"]));
    assert_eq!(default["link_storage"], "f32", "the default: {default}");
    assert_eq!(default["vector_storage"], "rgb", "the default");
    assert_eq!(wide["vector_storage"], "rgba");
    assert_eq!(packed["link_storage"], "packed");
    for json in [&default, &wide, &packed] {
        assert_eq!(json["multigrid"]["state"], "Converged", "{json}");
    }
    assert_eq!(default["multigrid"]["cycles"], wide["multigrid"]["cycles"]);
    assert!(multigrid_per_node(&default) < multigrid_per_node(&wide));
    assert!(multigrid_per_node(&packed) < multigrid_per_node(&default));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn coarse_options_need_the_multigrid_schedule() {
    let dir = scratch("coarse-cascade");
    for option in [
        ["--coarse-operator", "rediscretized"],
        ["--coarse-storage", "f32"],
        ["--coarse-drop", "0.02"],
        ["--link-storage", "f32"],
        ["--vector-storage", "rgba"],
    ] {
        let out = render(
            &dir,
            &[&["--schedule", "cascade"][..], &option[..]].concat(),
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{option:?} ran under the cascade");
        assert!(stderr.contains("--schedule multigrid"), "{stderr}");
    }
    let out = render(&dir, &["--coarse-drop", "1.5"]);
    assert!(!out.status.success(), "--coarse-drop 1.5 accepted");
    let _ = std::fs::remove_dir_all(&dir);
}
