//! How the command line reports bad input (issues 16 and 17): one `error:` line with each cause
//! once, OBJ problems at `FILE:LINE:`, resource limits named with the variable that raises them;
//! all before any output is written.

mod common;

use common::{scratch, translucent};

/// Runs a command expected to fail and returns its single error line.
fn error_line(args: &[&str], dir: &std::path::Path, env: &[(&str, &str)]) -> String {
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_translucent"));
    command
        .args(args)
        .env("TRANSLUCENT_DEVICE", "llvmpipe")
        .env("TRANSLUCENT_CACHE_DIR", dir);
    for (k, v) in env {
        command.env(k, v);
    }
    let o = command.output().expect("run translucent");
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{args:?}: {stderr}");
    let lines: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("error: "))
        .collect();
    assert_eq!(lines.len(), 1, "{args:?}: {stderr}");
    lines[0].to_string()
}

#[test]
fn each_cause_is_printed_once() {
    let dir = scratch("causes");
    let empty = dir.join("empty.obj");
    std::fs::write(&empty, "v 0 0 0\nv 1 0 0\n").expect("write");
    let out = dir.join("x.png");
    let line = error_line(
        &[
            "render",
            "--mesh",
            empty.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ],
        &dir,
        &[],
    );
    assert_eq!(line.matches("no triangles").count(), 1, "{line}");
    assert!(
        line.contains("empty.obj: the mesh has no triangles"),
        "{line}"
    );
    // A chain whose causes are not repeated keeps every one of them.
    let missing = dir.join("missing.obj");
    let line = error_line(
        &["bake", "--mesh", missing.to_str().expect("utf-8")],
        &dir,
        &[],
    );
    assert!(
        line.contains("missing.obj") && line.contains("No such file"),
        "{line}"
    );
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_obj_cut_inside_a_vertex_line_names_the_file_and_line() {
    let dir = scratch("cut-obj");
    let cut = dir.join("cut.obj");
    std::fs::write(
        &cut,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nv 0.25 0.5",
    )
    .expect("write");
    let path = cut.to_str().expect("utf-8");
    let line = error_line(
        &["bake", "--mesh", path, "--resolution", "4", "--levels", "1"],
        &dir,
        &[],
    );
    assert_eq!(
        line,
        format!("error: {path}:9: vertex 5: coordinate z is missing"),
        "{line}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn limits_are_named_with_the_variable_that_raises_them() {
    let dir = scratch("limits");
    let tetra = dir.join("tetra.obj");
    std::fs::write(
        &tetra,
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .expect("write");
    let tetra = tetra.to_str().expect("utf-8");
    // The cache file goes to the scratch directory, not the working directory.
    let cache = dir.join("tetra.qgraph");
    let bake = [
        "bake",
        "--mesh",
        tetra,
        "--resolution",
        "16",
        "--levels",
        "1",
        "--out",
        cache.to_str().expect("utf-8"),
    ];
    for (var, needle) in [
        (
            "TRANSLUCENT_MAX_TRIANGLES",
            "too many triangles: 4, the limit is 3",
        ),
        (
            "TRANSLUCENT_MAX_VERTICES",
            "too many vertices: 4, the limit is 3",
        ),
        ("TRANSLUCENT_MAX_FILE_BYTES", "too many bytes in the file"),
        ("TRANSLUCENT_MAX_LATTICE_NODES", "too many lattice nodes"),
        (
            "TRANSLUCENT_MAX_SURFACE_SAMPLES",
            "too many surface samples",
        ),
    ] {
        let line = error_line(&bake, &dir, &[(var, "3")]);
        assert!(
            line.contains(needle) && line.contains(&format!("{var}=N")),
            "{var}: {line}"
        );
    }
    // Raised, the same bake runs.
    let o = translucent(&bake, &dir);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // A .vol header announcing more voxels than allowed is refused before its data is read.
    let vol = dir.join("big.vol");
    let mut header = b"VOL\x03".to_vec();
    for v in [1i32, 4096, 4096, 4096, 6] {
        header.extend_from_slice(&v.to_le_bytes());
    }
    for v in [-1f32, -1.0, -1.0, 1.0, 1.0, 1.0] {
        header.extend_from_slice(&v.to_le_bytes());
    }
    std::fs::write(&vol, &header).expect("write");
    let out = dir.join("v.png");
    let line = error_line(
        &[
            "render",
            "--volume",
            vol.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ],
        &dir,
        &[],
    );
    assert!(line.contains("TRANSLUCENT_MAX_VOL_VOXELS=N"), "{line}");
    assert!(!out.exists());
    // An environment map above the texel limit is refused from its header, before its pixels.
    let env = dir.join("sky.exr");
    exr::prelude::write_rgb_file(&env, 8, 4, |_, _| (0.5f32, 0.5f32, 0.5f32)).expect("write EXR");
    let line = error_line(
        &[
            "render",
            "--env",
            env.to_str().expect("utf-8"),
            "--out",
            out.to_str().expect("utf-8"),
        ],
        &dir,
        &[("TRANSLUCENT_MAX_ENV_TEXELS", "31")],
    );
    assert!(
        line.contains("too many texels in the environment map: 32, the limit is 31")
            && line.contains("TRANSLUCENT_MAX_ENV_TEXELS=N"),
        "{line}"
    );
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn render_graph_refuses_files_and_options_it_cannot_use() {
    let dir = scratch("graph-errors");
    let path = |name: &str| dir.join(name).to_str().expect("utf-8").to_string();
    let (sphere, out) = (path("sphere.qgraph"), path("x.png"));
    let baked = translucent(
        &[
            "bake",
            "--shape",
            "sphere",
            "--size-mm",
            "20",
            "--resolution",
            "12",
            "--levels",
            "2",
            "--out",
            &sphere,
        ],
        &dir,
    );
    assert!(
        baked.status.success(),
        "{}",
        String::from_utf8_lossy(&baked.stderr)
    );
    let render = |extra: &[&str]| {
        let mut args = vec!["render", "--size-mm", "20", "--out", &out];
        args.extend(extra);
        error_line(&args, &dir, &[])
    };
    // Not a graph at all.
    let text = path("notes.qgraph");
    std::fs::write(&text, "not a graph\n").expect("write");
    let line = render(&["--shape", "sphere", "--graph", &text]);
    assert!(
        line.contains("--graph") && line.contains("not a QuadGraph cache file"),
        "{line}"
    );
    // Another format version (the header's version field, bytes 8..12).
    let mut bytes = std::fs::read(&sphere).expect("read the bake");
    bytes[8..12].copy_from_slice(&u32::MAX.to_le_bytes());
    let old = path("old.qgraph");
    std::fs::write(&old, &bytes).expect("write");
    let line = render(&["--shape", "sphere", "--graph", &old]);
    assert!(line.contains("format version"), "{line}");
    // Baked from another surface: the default torus, or the sphere at another size.
    let line = render(&["--graph", &sphere]);
    assert!(
        line.contains("baked from another surface") && line.contains("shape-torus"),
        "{line}"
    );
    let line = error_line(
        &[
            "render",
            "--shape",
            "sphere",
            "--size-mm",
            "30",
            "--graph",
            &sphere,
            "--out",
            &out,
        ],
        &dir,
        &[],
    );
    assert!(line.contains("baked from another surface"), "{line}");
    // Methods that read no QuadGraph.
    for method in ["voxel", "dipole", "auto"] {
        let line = render(&["--shape", "sphere", "--graph", &sphere, "--method", method]);
        assert!(
            line.contains("--method quadgraph only") && line.contains(method),
            "{line}"
        );
    }
    // The bake's own options are the file's (a usage error from the option parser: exit 2).
    for (option, value) in [("--levels", "3"), ("--resolution", "24"), ("-K", "0")] {
        let o = translucent(
            &[
                "render", "--shape", "sphere", "--graph", &sphere, option, value, "--out", &out,
            ],
            &dir,
        );
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{option}: {stderr}");
        assert!(
            stderr.contains("--graph") && stderr.contains("cannot be used"),
            "{stderr}"
        );
    }
    assert!(
        !dir.join("x.png").exists(),
        "a refused render wrote its image"
    );
}

#[test]
fn no_vulkan_driver_names_the_packages_to_install() {
    let dir = scratch("no-driver");
    // The loader with no driver to load (both the current and the older variable).
    let line = error_line(
        &["info"],
        &dir,
        &[
            ("VK_DRIVER_FILES", "/nonexistent/icd.json"),
            ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
        ],
    );
    assert!(
        line.contains("found no driver") && line.contains("apt-get install mesa-vulkan-drivers"),
        "{line}"
    );
}

/// Grosjean's diffusion coefficient belongs to the QuadGraph method: naming it with another
/// method is an error that says so, before any output is written.
#[test]
fn grosjean_diffusion_coefficient_with_another_method_is_named() {
    let dir = scratch("diffusion-coefficient");
    let out = dir.join("x.png");
    for method in ["voxel", "dipole"] {
        let line = error_line(
            &[
                "render",
                "--shape",
                "sphere",
                "--method",
                method,
                "--diffusion-coefficient",
                "grosjean",
                "--out",
                out.to_str().expect("utf-8"),
            ],
            &dir,
            &[],
        );
        assert!(
            line.contains("--diffusion-coefficient grosjean applies to --method quadgraph"),
            "{method}: {line}"
        );
    }
    assert!(!out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}
