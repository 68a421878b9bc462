//! The bad-input rows of the stress matrix: NaN and Inf through the library, and the command
//! line end to end (typed errors, no half-written files).

use super::*;

/// Case 7: NaN and Inf in every input, through the library: each must be a typed error.
pub(super) fn case_bad_input_library(rows: &mut Vec<Row>, ctx: &Context, dir: &Path) -> Result<()> {
    let mut check = |variant: &str, outcome: std::result::Result<(), String>| {
        let mut row = Row::new("NaN / Inf input", variant, "library");
        row.error_expected = true;
        row.typed_error = outcome.err();
        rows.push(row);
    };
    let err = |e: &dyn std::fmt::Display| e.to_string();
    check(
        "Material sigma_a = NaN",
        Material::new([1.0; 3], [f64::NAN, 0.0, 0.0], 1.3)
            .map(drop)
            .map_err(|e| err(&e)),
    );
    let marble = Material::preset("marble")?;
    check(
        "preset x inf",
        Material::new(
            marble.sigma_s.map(|v| v * f64::INFINITY),
            marble.sigma_a.map(|v| v * f64::INFINITY),
            1.3,
        )
        .map(drop)
        .map_err(|e| err(&e)),
    );
    check(
        "preset x 0 (sigma_t' = 0)",
        Material::new([0.0; 3], [0.0; 3], 1.3)
            .map(drop)
            .map_err(|e| err(&e)),
    );
    check(
        "eta = NaN",
        Material::new([1.0; 3], [0.0; 3], f64::NAN)
            .map(drop)
            .map_err(|e| err(&e)),
    );
    check(
        "procedural split with an inf coefficient",
        Coefficients::new([f64::INFINITY, 1.0, 1.0], [0.0; 3])
            .map(drop)
            .map_err(|e| err(&e)),
    );
    for light in [
        Light::Directional {
            direction: DVec3::new(f64::NAN, -1.0, 0.0),
            irradiance: [1.0; 3],
        },
        Light::Directional {
            direction: DVec3::new(1e-320, 0.0, 0.0),
            irradiance: [1.0; 3],
        },
        Light::Directional {
            direction: DVec3::NEG_Y,
            irradiance: [f64::INFINITY, 1.0, 1.0],
        },
        Light::Point {
            position: DVec3::new(0.0, f64::INFINITY, 0.0),
            intensity: [1.0; 3],
        },
        Light::Spot {
            position: DVec3::new(0.0, 50.0, 0.0),
            direction: DVec3::NEG_Y,
            intensity: [1.0; 3],
            inner_deg: f64::NAN,
            outer_deg: 20.0,
        },
    ] {
        check(
            &format!("light {light:?}"),
            light.validate().map_err(|e| err(&e)),
        );
    }
    check(
        "environment constant NaN",
        Environment::Constant([f64::NAN, 0.0, 0.0])
            .validate()
            .map_err(|e| err(&e)),
    );
    check(
        "environment constant inf",
        Environment::Constant([f64::INFINITY; 3])
            .validate()
            .map_err(|e| err(&e)),
    );
    for camera in [
        Camera {
            eye: DVec3::new(f64::NAN, 0.0, 100.0),
            target: DVec3::ZERO,
            fovy_deg: 40.0,
        },
        Camera {
            eye: DVec3::new(0.0, 0.0, 100.0),
            target: DVec3::ZERO,
            fovy_deg: f64::INFINITY,
        },
        Camera {
            eye: DVec3::new(0.0, 0.0, 1e300),
            target: DVec3::ZERO,
            fovy_deg: 40.0,
        },
    ] {
        check(
            &format!("camera {camera:?}"),
            camera.validate().map_err(|e| err(&e)),
        );
    }
    let (v, f) = box_mesh(DVec3::splat(10.0));
    for bad in [f64::NAN, f64::INFINITY, 1e300] {
        let mut v = v.clone();
        v[3].y = bad;
        let path = dir.join("bad_vertex.obj");
        write_obj(&path, &v, &f)?;
        check(
            &format!("OBJ vertex y = {bad:e}"),
            TriMesh::load_obj(&path)
                .and_then(|mut m| m.validate(&ValidateOptions::default()).map(drop))
                .map_err(|e| err(&e)),
        );
    }
    let unit = TriMesh {
        positions: v.clone(),
        normals: vec![],
        indices: f.clone(),
    };
    for size in [f64::NAN, f64::INFINITY, 0.0, -1.0, 1e300, 1e-300] {
        check(
            &format!("size_mm = {size:e}"),
            unit.normalized(size).map(drop).map_err(|e| err(&e)),
        );
    }
    // A .vol grid with a NaN voxel (the file written by hand: VolGrid refuses to hold one).
    let grid = VolGrid::from_fn([2, 2, 2], DVec3::splat(-1.0), DVec3::splat(1.0), |_| {
        ([1.0; 3], [0.1; 3])
    })?;
    for bad in [f32::NAN, f32::INFINITY] {
        let mut bytes = grid.to_bytes();
        let at = bytes.len() - 4;
        bytes[at..].copy_from_slice(&bad.to_le_bytes());
        let path = dir.join("bad.vol");
        std::fs::write(&path, bytes)?;
        check(
            &format!(".vol voxel = {bad}"),
            VolGrid::read(&path).map(drop).map_err(|e| err(&e)),
        );
    }
    // q uploaded by a host: NaN and values that overflow fp16 at the chosen exposure.
    let graph = sphere(20.0, 8, 1)?;
    let field = MaterialField::Homogeneous(marble);
    let mut solve = GpuDiffusion::new(ctx, &graph, &field, &GpuSolveParams::default())?;
    let n = graph.levels[0].surface_count();
    check(
        "GPU q upload NaN",
        solve
            .upload_q(ctx, 0, &vec![[f32::NAN; 3]; n])
            .map_err(|e| err(&e)),
    );
    check(
        "GPU q upload inf",
        solve
            .upload_q(ctx, 0, &vec![[f32::INFINITY; 3]; n])
            .map_err(|e| err(&e)),
    );
    Ok(())
}

/// The `translucent` binary next to this one (cargo puts both in `target/release`).
fn cli_binary() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let path = exe
        .parent()?
        .join(format!("translucent{}", std::env::consts::EXE_SUFFIX));
    path.is_file().then_some(path)
}

/// Case 7 (and 4, 5) end to end through `translucent render`: bad input exits non-zero with a
/// message and writes no file; extreme but valid input exits 0 with no `null` (serde_json's NaN)
/// in the JSON.
pub(super) fn case_cli(rows: &mut Vec<Row>, dir: &Path) -> Result<()> {
    let Some(exe) = cli_binary() else {
        let mut row = Row::new("command line", "all", "cli");
        row.note =
            "skipped: build translucent-tools (cargo build --release -p translucent-tools)".into();
        rows.push(row);
        return Ok(());
    };
    let nan_obj = dir.join("nan_vertex.obj");
    let (mut v, f) = box_mesh(DVec3::splat(10.0));
    v[2].x = f64::NAN;
    write_obj(&nan_obj, &v, &f)?;
    let nan_vol = dir.join("nan.vol");
    {
        let grid = VolGrid::from_fn([2, 2, 2], DVec3::splat(-30.0), DVec3::splat(30.0), |_| {
            ([1.0; 3], [0.1; 3])
        })?;
        let mut bytes = grid.to_bytes();
        let at = bytes.len() - 4;
        bytes[at..].copy_from_slice(&f32::NAN.to_le_bytes());
        std::fs::write(&nan_vol, bytes)?;
    }
    let nan_obj = nan_obj.to_string_lossy().into_owned();
    let nan_vol = nan_vol.to_string_lossy().into_owned();
    let bad: Vec<(String, Vec<&str>)> = vec![
        (
            "--sigma-a nan".into(),
            vec!["--sigma-a", "nan,0,0", "--sigma-s", "1,1,1"],
        ),
        (
            "--sigma-s inf".into(),
            vec!["--sigma-a", "0,0,0", "--sigma-s", "inf,1,1"],
        ),
        ("--eta nan".into(), vec!["--eta", "nan"]),
        (
            "--light colour nan".into(),
            vec!["--light", "dir:0,-1,0:nan,1,1"],
        ),
        (
            "--light direction inf".into(),
            vec!["--light", "dir:inf,-1,0:1,1,1"],
        ),
        (
            "--light position nan".into(),
            vec!["--light", "point:nan,0,0:1,1,1"],
        ),
        (
            "--light 1e300".into(),
            vec!["--light", "dir:0,-1,0:1e300,1e300,1e300"],
        ),
        (
            "--camera eye nan".into(),
            vec!["--camera", "nan,0,0:0,0,0:40"],
        ),
        (
            "--camera eye 1e300".into(),
            vec!["--camera", "0,0,1e300:0,0,0:40"],
        ),
        (
            "--env-constant nan".into(),
            vec!["--env-constant", "nan,1,1"],
        ),
        (
            "--env-constant inf".into(),
            vec!["--env-constant", "inf,1,1"],
        ),
        ("--size-mm nan".into(), vec!["--size-mm", "nan"]),
        ("--size-mm inf".into(), vec!["--size-mm", "inf"]),
        ("--size-mm 1e300".into(), vec!["--size-mm", "1e300"]),
        ("--size-mm 1e-300".into(), vec!["--size-mm", "1e-300"]),
        ("OBJ vertex NaN".into(), vec!["--mesh", &nan_obj]),
        (".vol voxel NaN".into(), vec!["--volume", &nan_vol]),
    ];
    let good: Vec<(String, Vec<&str>)> = vec![
        ("--size-mm 1".into(), vec!["--size-mm", "1"]),
        ("--size-mm 10000".into(), vec!["--size-mm", "10000"]),
        (
            "--light 1e-4".into(),
            vec!["--light", "dir:0,-1,0:1e-4,1e-4,1e-4"],
        ),
        (
            "--light 1e4".into(),
            vec!["--light", "dir:0,-1,0:1e4,1e4,1e4"],
        ),
        (
            "--sigma-a 0".into(),
            vec!["--sigma-a", "0,0,0", "--sigma-s", "1,1,1"],
        ),
        (
            "--sigma-a 1e4".into(),
            vec!["--sigma-a", "1e4,1e4,1e4", "--sigma-s", "1,1,1"],
        ),
    ];
    for (expect_error, cases) in [(true, bad), (false, good)] {
        for (variant, extra) in cases {
            for solver in ["cpu", "gpu"] {
                let out = dir.join("cli.exr");
                let _ = std::fs::remove_file(&out);
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
                ];
                if !extra.contains(&"--mesh") {
                    args.extend(["--shape", "sphere"]);
                }
                if !extra.contains(&"--size-mm") {
                    args.extend(["--size-mm", "20"]);
                }
                args.extend(extra.iter().copied());
                let out_text = out.to_string_lossy().into_owned();
                args.extend(["--out", &out_text]);
                let run = Command::new(&exe)
                    .args(&args)
                    .env("TRANSLUCENT_VALIDATION", "1")
                    .env("TRANSLUCENT_CACHE_DIR", dir.join("cache"))
                    .output()?;
                let mut row = Row::new("command line", variant.clone(), format!("cli {solver}"));
                row.reference =
                    "exit status; no file on error; else problems: null in JSON, EXR not finite, no file";
                row.error_expected = expect_error;
                let stderr = String::from_utf8_lossy(&run.stderr);
                let stdout = String::from_utf8_lossy(&run.stdout);
                let written = out.exists();
                if run.status.success() {
                    // serde_json prints NaN and Inf as null.
                    row.nonfinite = stdout.matches("null").count()
                        - stdout.matches("\"exact_iterations\":null").count()
                        - stdout.matches("\"precision\":null").count()
                        - stdout.matches("\"gpu_bytes\":null").count();
                    row.note = if written {
                        // The library's EXR reader refuses any texel that is not finite and >= 0.
                        match Environment::load_exr(&out) {
                            Ok(_) => "EXR finite and >= 0".into(),
                            Err(e) => {
                                row.nonfinite += 1;
                                format!("EXR: {e}")
                            }
                        }
                    } else {
                        "NO FILE".into()
                    };
                    // Problems found: NaN/Inf in the JSON or the EXR, or no file.
                    row.error = Some((row.nonfinite + usize::from(!written)) as f64);
                    row.tolerance = Some(0.0);
                } else {
                    let message = stderr
                        .lines()
                        .find(|l| l.starts_with("error"))
                        .unwrap_or("(no error line)")
                        .to_string();
                    row.typed_error = Some(format!("exit {:?}: {message}", run.status.code()));
                    if written {
                        row.nonfinite += 1;
                        row.note = "a file was written despite the error".into();
                    }
                }
                eprintln!("cli {variant} {solver}: {}", row.result_text());
                rows.push(row);
            }
        }
    }
    Ok(())
}
