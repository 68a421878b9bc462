//! `--method auto` on `render` (the rule of `frame::choose_method` picks, and the choice and its
//! reason come back in `--json` from the FrameReport) and `bench --method`'s bad input.

mod common;

use common::{json_of, scratch, translucent};

/// The heterogeneous split sphere of the path-traced references.
fn split_volume() -> String {
    format!(
        "{}/../tests/reference/pt/milk-skin-split.vol",
        env!("CARGO_MANIFEST_DIR")
    )
}

#[test]
fn render_method_auto_picks_by_the_scene_and_reports_why() {
    let dir = scratch("auto");
    let volume = split_volume();
    // A heterogeneous material: quadgraph (rule 2), on a small lattice so the test stays fast.
    let png = dir.join("split.png");
    let v = json_of(&translucent(
        &[
            "render",
            "--method",
            "auto",
            "--shape",
            "sphere",
            "--size-mm",
            "20",
            "--volume",
            &volume,
            "--resolution",
            "12",
            "--levels",
            "2",
            "--width",
            "48",
            "--height",
            "48",
            "--out",
            png.to_str().expect("utf-8 path"),
            "--json",
        ],
        &dir,
    ));
    assert_eq!(v["method"], "quadgraph", "{v}");
    assert_eq!(v["method_choice"]["method"], "quadgraph", "{v}");
    let reason = v["method_choice"]["reason"].as_str().expect("reason");
    assert!(reason.contains("heterogeneous"), "{reason}");
    assert!(png.is_file());

    // A homogeneous sphere under an environment only: quadgraph (rule 3).
    let png = dir.join("env.png");
    let v = json_of(&translucent(
        &[
            "render",
            "--method",
            "auto",
            "--shape",
            "sphere",
            "--size-mm",
            "20",
            "--material",
            "marble",
            "--env-constant",
            "1,1,1",
            "--light",
            "dir:0,-1,0:0,0,0",
            "--resolution",
            "12",
            "--levels",
            "2",
            "--width",
            "48",
            "--height",
            "48",
            "--out",
            png.to_str().expect("utf-8 path"),
            "--json",
        ],
        &dir,
    ));
    assert_eq!(v["method"], "quadgraph", "{v}");
    assert_eq!(v["method_choice"]["method"], "quadgraph", "{v}");
    let reason = v["method_choice"]["reason"].as_str().expect("reason");
    assert!(reason.contains("environment"), "{reason}");

    // A method given by name reports no choice.
    let v = json_of(&translucent(
        &[
            "render",
            "--method",
            "voxel",
            "--shape",
            "sphere",
            "--size-mm",
            "20",
            "--voxels",
            "8",
            "--width",
            "32",
            "--height",
            "32",
            "--out",
            png.to_str().expect("utf-8 path"),
            "--json",
        ],
        &dir,
    ));
    assert!(v["method_choice"].is_null(), "{v}");
}

#[test]
fn bad_method_input_is_refused_with_a_message() {
    let dir = scratch("methods-bad");
    let out = dir.join("never.png");
    let out_s = out.to_str().expect("utf-8 path");
    let bench_out = dir.join("bench");
    let bench_s = bench_out.to_str().expect("utf-8 path");
    for (args, needle) in [
        (
            vec![
                "render", "--method", "auto", "--solver", "cpu", "--out", out_s,
            ],
            "--method auto",
        ),
        (
            vec!["bench", "--method", "voxel,photon", "--out", bench_s],
            "photon",
        ),
        (
            vec![
                "bench", "--method", "voxel", "--scenes", "teapot", "--out", bench_s,
            ],
            "teapot",
        ),
        (
            vec![
                "bench", "--method", "voxel", "--shape", "sphere", "--out", bench_s,
            ],
            "--shape",
        ),
    ] {
        let o = translucent(&args, &dir);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert!(!out.exists() && !bench_out.exists(), "{args:?} left output");
    }
}
