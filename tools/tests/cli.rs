//! The command line as a user runs it: `translucent render`, `bake` and `info`, with validation on
//! (any validation message makes the command fail). Small graphs and images keep this fast on
//! lavapipe.

mod common;

use common::{json_of, rgb, scratch, translucent};

const SMALL: [&str; 10] = [
    "--resolution",
    "16",
    "--levels",
    "2",
    "--width",
    "64",
    "--height",
    "64",
    "--size-mm",
    "20",
];

#[test]
fn render_solves_balances_energy_and_only_the_first_frame_solves() {
    let dir = scratch("render");
    let png = dir.join("sphere.png");
    let mut args = vec![
        "render",
        "--solver",
        "cpu",
        "--shape",
        "sphere",
        "--material",
        "marble",
        "--frames",
        "3",
    ];
    args.extend(SMALL);
    args.extend(["--out", png.to_str().expect("utf-8 path"), "--json"]);
    let v = json_of(&translucent(&args, &dir));

    assert!(v["device"].as_str().expect("device").contains("llvmpipe"));
    let levels = v["levels"].as_array().expect("levels");
    assert_eq!(levels.len(), 2);
    assert!(
        levels[1]["surface_nodes"].as_u64() > levels[0]["surface_nodes"].as_u64(),
        "finer level has more surface nodes: {levels:?}"
    );
    // fv conserves energy exactly: what enters leaves or is absorbed (DESIGN section 2).
    let e = &v["energy"];
    let (input, exit, absorbed) = (
        rgb(&e["transmitted_input"]),
        rgb(&e["exitance"]),
        rgb(&e["absorbed"]),
    );
    for c in 0..3 {
        assert!(input[c] > 0.0 && exit[c] > 0.0 && absorbed[c] > 0.0);
        let balance = (input[c] - exit[c] - absorbed[c]).abs() / input[c];
        assert!(
            balance < 1e-6,
            "channel {c}: {input:?} vs {exit:?} + {absorbed:?}"
        );
    }
    let frames = v["frames"].as_array().expect("frames");
    assert_eq!(frames.len(), 3);
    let iterations = |f: &serde_json::Value| -> u64 {
        f["iterations"]
            .as_array()
            .expect("iterations")
            .iter()
            .map(|i| i.as_u64().expect("count"))
            .sum()
    };
    assert!(iterations(&frames[0]) > 0, "the first frame solves");
    assert_eq!(
        iterations(&frames[1]) + iterations(&frames[2]),
        0,
        "later frames do not"
    );
    assert!(
        frames[2]["passes"].get("shading").is_some(),
        "{:?}",
        frames[2]
    );

    let image = image::open(&png).expect("the PNG was written").to_rgb8();
    assert_eq!(image.dimensions(), (64, 64));
    let lit = image
        .pixels()
        .filter(|p| p.0.iter().any(|&c| c > 20))
        .count();
    assert!(
        lit > 64 * 64 / 10,
        "the object covers the middle of the frame: {lit} lit pixels"
    );
    assert!(image.get_pixel(0, 0).0 == [0, 0, 0], "background is black");
}

#[test]
fn render_writes_linear_exr_and_a_cached_bake_is_reused() {
    let dir = scratch("exr");
    let exr = dir.join("torus.exr");
    let mut args = vec![
        "render",
        "--solver",
        "cpu",
        "--shape",
        "torus",
        "--env-constant",
        "0.5,0.5,0.5",
        "--no-specular",
    ];
    args.extend(SMALL);
    args.extend(["--out", exr.to_str().expect("utf-8 path"), "--json"]);
    let first_run = translucent(&args, &dir);
    let first = json_of(&first_run);
    let second = json_of(&translucent(&args, &dir));
    assert!(exr.is_file());
    let said = String::from_utf8_lossy(&first_run.stderr);
    assert!(
        said.lines()
            .any(|l| l.starts_with(&format!("wrote {}", exr.display())) && l.contains(" x ")),
        "render says what it wrote: {said}"
    );
    assert_eq!(first["cache"], second["cache"]);
    // Same graph, same solution; parallel reductions may differ in the last bits only.
    for key in ["transmitted_input", "exitance", "absorbed"] {
        let (a, b) = (rgb(&first["energy"][key]), rgb(&second["energy"][key]));
        for c in 0..3 {
            assert!(
                (a[c] - b[c]).abs() <= 1e-9 * a[c].abs(),
                "{key}: {a:?} vs {b:?}"
            );
        }
    }
    assert!(
        second["frames"][0]["passes"].get("shadow_map").is_none(),
        "--no-specular records no shadow pass"
    );
}

#[test]
fn bad_input_is_refused_with_a_message_and_no_output_file() {
    let dir = scratch("bad");
    let out = dir.join("never.png");
    let out_s = out.to_str().expect("utf-8 path");
    let triangle = dir.join("triangle.obj");
    std::fs::write(&triangle, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").expect("obj");
    let triangle_s = triangle.to_str().expect("utf-8 path");
    let truncated = dir.join("truncated.obj");
    std::fs::write(&truncated, "v 0 0 0\nv 1 0 0\nv 0 1").expect("obj");
    let truncated_s = truncated.to_str().expect("utf-8 path");
    for (args, needle) in [
        // A single triangle encloses nothing: the advice is a closed solid, not a finer lattice.
        (
            vec!["render", "--mesh", triangle_s, "--force", "--out", out_s],
            "open surface",
        ),
        (
            vec!["render", "--mesh", truncated_s, "--out", out_s],
            "truncated.obj:3: vertex 3: coordinate z is missing",
        ),
        (vec!["render", "--out", "x.bmp"], "--out"),
        (
            vec!["render", "--material", "cheese", "--out", out_s],
            "cheese",
        ),
        (
            vec![
                "render",
                "--sigma-a",
                "0.1,0.1",
                "--sigma-s",
                "1,1,1",
                "--out",
                out_s,
            ],
            "--sigma-a",
        ),
        (
            vec![
                "render",
                "--sigma-a=-1,0,0",
                "--sigma-s",
                "1,1,1",
                "--out",
                out_s,
            ],
            "sigma",
        ),
        (
            vec!["render", "--light", "dir:0,0,0:1,1,1", "--out", out_s],
            "--light",
        ),
        (
            vec!["render", "--size-mm", "-3", "--out", out_s],
            "--size-mm",
        ),
        (
            vec!["render", "--texture-only", "--out", out_s],
            "--texture-only",
        ),
        (
            vec![
                "render", "--method", "voxel", "--solver", "cpu", "--out", out_s,
            ],
            "voxel",
        ),
        (
            vec![
                "render", "--method", "voxel", "--voxels", "3", "--out", out_s,
            ],
            "--voxels",
        ),
        (
            vec!["render", "--voxel-model", "paper", "--out", out_s],
            "--method voxel",
        ),
        (
            vec!["render", "--mesh", "/nonexistent/x.obj", "--out", out_s],
            "x.obj",
        ),
        (vec!["bake", "--shape", "cube"], "cube"),
    ] {
        let o = translucent(&args, &dir);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
        assert_eq!(
            stderr.lines().filter(|l| l.starts_with("error")).count(),
            1,
            "{args:?}: one error line: {stderr}"
        );
        assert!(!out.exists(), "{args:?} left an output file");
    }
}

#[test]
fn an_unwritable_out_fails_before_the_bake_with_one_error_line() {
    let dir = scratch("unwritable");
    let missing = dir.join("no-such-folder").join("x.png");
    let folder = dir.join("a-folder.png");
    std::fs::create_dir_all(&folder).expect("folder");
    for (out, needle) in [(&missing, "does not exist"), (&folder, "is a folder")] {
        let o = translucent(
            &[
                "render",
                "--shape",
                "sphere",
                "--out",
                out.to_str().expect("utf-8"),
            ],
            &dir,
        );
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{out:?} succeeded");
        assert!(stderr.contains(needle), "{out:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
        let bakes = std::fs::read_dir(&dir)
            .expect("dir")
            .filter(|e| {
                e.as_ref()
                    .is_ok_and(|e| e.file_name().to_string_lossy().ends_with(".qgraph"))
            })
            .count();
        assert_eq!(bakes, 0, "{out:?}: baked before refusing");
    }
}

#[test]
fn info_names_the_device_with_validation_on() {
    let dir = scratch("info");
    let v = json_of(&translucent(&["info", "--json"], &dir));
    let text = v.to_string();
    assert!(text.contains("llvmpipe"), "{text}");
}
