//! `translucent bench`: a tiny sweep under validation (a marble sphere in a white environment, so
//! all three errors exist: the exact discrete solution, the closed form, and a reference image
//! rendered by `translucent render --solver cpu` of the same scene), and bad lists.

mod common;

use std::collections::HashMap;
use std::path::Path;

use common::{json_of, scratch, translucent};

const SCENE: &[&str] = &[
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
    "--camera",
    "0,20,60:0,0,0:30",
    "--resolution",
    "12",
    "--levels",
    "2",
    "--no-specular",
    "-K",
    "1",
];

const COLUMNS: &str =
    "solver,family,family_name,colour,k,levels,resolution,scheme,precision,start,schedule,\
iterations_cap,tolerance,iterations_per_level,node_updates,finest_nodes,finest_surface_nodes,solve_gpu_ms,\
frame_gpu_ms,cpu_s,gpu_bytes,bytes_per_node,discrete_r,discrete_g,discrete_b,discrete_all,\
solver_r,solver_g,solver_b,solver_all,\
closed_form_r,closed_form_g,closed_form_b,closed_form_all,image_r,image_g,image_b,image_all,\
pareto_solver,pareto_image,bounce,exit_lobe";

fn read_csv(path: &Path) -> Vec<HashMap<String, String>> {
    let text = std::fs::read_to_string(path).expect("bench.csv");
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().expect("header").split(',').collect();
    assert_eq!(header.join(","), COLUMNS, "the CSV columns");
    lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            assert_eq!(cells.len(), header.len(), "{l}");
            header
                .iter()
                .zip(cells)
                .map(|(h, c)| (h.to_string(), c.to_string()))
                .collect()
        })
        .collect()
}

fn number(row: &HashMap<String, String>, column: &str) -> f64 {
    let v: f64 = row[column]
        .parse()
        .unwrap_or_else(|e| panic!("{column} = {:?}: {e}", row[column]));
    assert!(v.is_finite(), "{column} = {v}");
    v
}

#[test]
fn a_tiny_sweep_measures_all_three_errors_and_the_exact_row_is_its_own_zero() {
    let dir = scratch("bench-sweep");
    // The reference image: the exact (CPU) solution of the same scene, rendered by `render`.
    let reference = dir.join("reference.exr");
    let mut args = vec![
        "render",
        "--solver",
        "cpu",
        "--width",
        "48",
        "--height",
        "40",
        // The bench draws one sample per pixel.
        "--supersample",
        "1",
        // The bench's model: render's (and the library's) QuadGraph default is Grosjean's D; the
        // bench pins the material's own 1 / (3 sigma_t') for its exact-solution comparisons.
        "--diffusion-coefficient",
        "classical",
    ];
    args.extend(SCENE);
    args.extend(["--out", reference.to_str().expect("utf-8")]);
    let out = translucent(&args, &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let out_dir = dir.join("bench");
    let mut args = vec![
        "bench",
        "--iterations",
        "8,64",
        "--tolerance",
        "0",
        "--start",
        "cold,warm",
        "--repeats",
        "1",
        "--json",
        "--reference",
        reference.to_str().expect("utf-8"),
        "--out",
        out_dir.to_str().expect("utf-8"),
    ];
    args.extend(SCENE);
    let json = json_of(&translucent(&args, &dir));
    assert!(json["closed_form"].as_bool().expect("closed_form"));
    assert_eq!(
        json["reference_mask"], "nonblack",
        "render's EXR has no alpha"
    );
    assert!(out_dir.join("bench.png").is_file());
    let png = image::open(out_dir.join("bench.png")).expect("a PNG");
    assert!(png.width() > 100 && png.height() > 100);

    let rows = read_csv(&out_dir.join("bench.csv"));
    assert_eq!(rows.len(), 5, "one exact row and 2 caps x 2 starts");
    let exact: Vec<_> = rows.iter().filter(|r| r["solver"] == "exact").collect();
    let gpu: Vec<_> = rows.iter().filter(|r| r["solver"] == "gpu").collect();
    assert_eq!((exact.len(), gpu.len()), (1, 4));
    let exact = exact[0];
    for c in ["r", "g", "b", "all"] {
        assert_eq!(number(exact, &format!("discrete_{c}")), 0.0);
        assert_eq!(number(exact, &format!("solver_{c}")), 0.0);
        // The same solution drawn by the same renderer at the same camera and size: only the
        // last bits of the two solves' sums differ. A camera or size mix-up would be O(1).
        let image = number(exact, &format!("image_{c}"));
        assert!(image < 1e-4, "exact row image_{c} = {image}");
        // The discretization error of a 12-cell sphere against the closed form (2-4% measured);
        // its lower bound proves the closed form is not the discrete solution itself.
        let closed = number(exact, &format!("closed_form_{c}"));
        assert!((1e-3..0.1).contains(&closed), "closed_form_{c} = {closed}");
    }
    for row in &gpu {
        for column in [
            "solve_gpu_ms",
            "frame_gpu_ms",
            "gpu_bytes",
            "discrete_all",
            "solver_all",
            "closed_form_all",
            "image_all",
        ] {
            number(row, column);
        }
        assert!(number(row, "solve_gpu_ms") > 0.0);
        assert!(number(row, "frame_gpu_ms") >= number(row, "solve_gpu_ms"));
        let cap: u32 = row["iterations_cap"].parse().expect("cap");
        let per_level: Vec<u32> = row["iterations_per_level"]
            .split(';')
            .map(|v| v.parse().expect("iterations"))
            .collect();
        assert_eq!(per_level, vec![cap, cap], "tolerance 0 runs the cap");
        let nodes = number(row, "finest_nodes");
        let updates = number(row, "node_updates");
        assert!(
            updates > f64::from(cap) * nodes && updates < 2.0 * f64::from(cap) * nodes,
            "{updates} node updates for {cap} iterations on 2 levels, {nodes} finest nodes"
        );
    }
    let find = |start: &str, cap: &str| {
        *gpu.iter()
            .find(|r| r["start"] == start && r["iterations_cap"] == cap)
            .unwrap_or_else(|| panic!("{start} {cap}"))
    };
    let error = |start: &str, cap: &str| number(find(start, cap), "discrete_all");
    for start in ["cold", "warm"] {
        // Against the exact solution for the GPU's own gathered q: also shrinking, and the two
        // references differ only by the gather's error (q in fp16, no shadows here), which is
        // far below an unconverged solve's.
        let (few, many) = (find(start, "8"), find(start, "64"));
        assert!(number(many, "solver_all") <= number(few, "solver_all"));
        let gap = (number(few, "solver_all") - number(few, "discrete_all")).abs();
        assert!(gap < 0.1 * number(few, "discrete_all"), "{start}: {gap}");
    }
    for start in ["cold", "warm"] {
        assert!(
            error(start, "64") <= error(start, "8"),
            "{start}: more iterations must not increase the error: {} > {}",
            error(start, "64"),
            error(start, "8")
        );
    }
    // Eight cold iterations are far from converged; the metric sees it.
    assert!(error("cold", "8") > 1e-2, "{}", error("cold", "8"));
    // The light is dark and the environment constant: turning the lights changes nothing, so a
    // warm start continues from the previous frames' iterations (measured 0.23 against 0.39).
    assert!(
        error("warm", "8") < 0.8 * error("cold", "8"),
        "warm {} cold {}",
        error("warm", "8"),
        error("cold", "8")
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--bounce` and `--exit-lobe` are sweep axes: one GPU row per combination, named in the CSV.
/// Both act after the solve (the bounce on the displayed exitance, the lobe in the shading), so
/// the surface nodes' J+ (error (a)) is the same in every row, while the image against the
/// reference differs: a torus, whose hole gets bounce links (a sphere, convex, gets none).
#[test]
fn bounce_and_exit_lobe_are_sweep_axes() {
    let dir = scratch("bench-axes");
    let scene = [
        "--shape",
        "torus",
        "--size-mm",
        "20",
        "--material",
        "marble",
        "--light",
        "dir:0.3,-1,-0.4:2,2,2",
        "--camera",
        "0,30,50:0,0,0:35",
        "--width",
        "40",
        "--height",
        "32",
        "--resolution",
        "12",
        "--levels",
        "2",
        "--no-specular",
    ];
    let reference = dir.join("reference.exr");
    let mut args = vec![
        "render",
        "--solver",
        "cpu",
        "--supersample",
        "1",
        "--diffusion-coefficient",
        "classical",
        "--out",
        reference.to_str().expect("utf-8"),
    ];
    args.extend(scene);
    let out = translucent(&args, &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out_dir = dir.join("bench");
    let mut args = vec![
        "bench",
        "--tolerance",
        "1e-3",
        "--repeats",
        "1",
        "--bounce",
        "off,local",
        "--exit-lobe",
        "lambert,p1",
        "--reference",
        reference.to_str().expect("utf-8"),
        "--out",
        out_dir.to_str().expect("utf-8"),
    ];
    args.extend(scene);
    let out = translucent(&args, &dir);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows = read_csv(&out_dir.join("bench.csv"));
    let gpu: Vec<_> = rows.iter().filter(|r| r["solver"] == "gpu").collect();
    let mut combos: Vec<(String, String)> = gpu
        .iter()
        .map(|r| (r["bounce"].clone(), r["exit_lobe"].clone()))
        .collect();
    combos.sort();
    assert_eq!(
        combos,
        [
            ("local", "lambert"),
            ("local", "p1"),
            ("off", "lambert"),
            ("off", "p1")
        ]
        .map(|(b, l)| (b.to_string(), l.to_string()))
    );
    let row = |bounce: &str, lobe: &str| {
        gpu.iter()
            .find(|r| r["bounce"] == bounce && r["exit_lobe"] == lobe)
            .expect("row")
    };
    let plain = row("off", "lambert");
    for (bounce, lobe) in [("local", "lambert"), ("off", "p1"), ("local", "p1")] {
        let other = row(bounce, lobe);
        assert_eq!(
            other["discrete_all"], plain["discrete_all"],
            "{bounce} {lobe}: J+ of the surface nodes is the solve's"
        );
        assert_ne!(
            other["image_all"], plain["image_all"],
            "{bounce} {lobe}: the frame differs"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_lists_are_errors_naming_the_option_and_write_nothing() {
    let dir = scratch("bench-bad");
    let out_dir = dir.join("bench");
    let out = out_dir.to_str().expect("utf-8");
    for (bad, names) in [
        (vec!["--iterations", "8,x"], "--iterations"),
        (vec!["--iterations", "8,,16"], "--iterations"),
        (vec!["--iterations", "100000"], "timestamp scopes"),
        (vec!["--levels", "0"], "--levels"),
        (vec!["--resolution", "24,-3"], "--resolution"),
        (vec!["-K", "nan"], "-K"),
        (vec!["--tolerance", "1e-3,-1"], "--tolerance"),
        (vec!["--start", "cold,lukewarm"], "--start"),
        (vec!["--precision", "fp8"], "--precision"),
        (vec!["--scheme", "fem"], "--scheme"),
        (vec!["--repeats", "0"], "--repeats"),
        (vec!["--bounce", "off,twice"], "--bounce"),
        (vec!["--exit-lobe", "lambert,cosine"], "--exit-lobe"),
        (vec!["--suite", "nope"], "--suite"),
        (
            vec!["--reference", "missing.exr", "--camera", "0,20,60:0,0,0:30"],
            "missing.exr",
        ),
    ] {
        let mut args = vec!["bench", "--shape", "sphere"];
        args.extend(&bad);
        args.extend(["--out", out]);
        let result = translucent(&args, &dir);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert!(!result.status.success(), "{bad:?} was accepted");
        assert!(stderr.contains(names), "{bad:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{bad:?}: {stderr}");
        assert!(!out_dir.exists(), "{bad:?} wrote {}", out_dir.display());
    }
    // An output path that is a file: refused before anything runs, the file left as it was.
    let file = dir.join("file.txt");
    std::fs::write(&file, "keep").expect("write");
    let result = translucent(
        &[
            "bench",
            "--shape",
            "sphere",
            "--out",
            file.to_str().expect("utf-8"),
        ],
        &dir,
    );
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        !result.status.success() && stderr.contains("--out"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&file).expect("read"), "keep");
    let _ = std::fs::remove_dir_all(&dir);
}
