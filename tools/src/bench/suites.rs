//! The named suites of `translucent bench --suite` and how their options combine with the user's.

use super::*;

/// Re-parses a suite's options followed by the user's (later ones win).
#[derive(clap::Parser, Debug)]
#[command(name = "translucent bench", args_override_self = true)]
pub(super) struct SuiteCli {
    #[command(flatten)]
    pub(super) args: BenchArgs,
}

/// The camera every path-traced reference in `tests/reference/pt` uses (its README).
pub(super) const PT_CAMERA: &str = "0,20,60:0,0,0:30";

/// The suites: name, what it shows, its options. All but `schedules` pin `--schedule cascade`
/// (the bench's default is the library's multigrid) so their rows stay comparable with the
/// tables in benches/RESULTS.md. Paths are relative to the repository root;
/// meshes come from `$TRANSLUCENT_MESH_DIR` (default `../shared/meshes`).
#[rustfmt::skip]
pub(super) const SUITES: [(&str, &str, &[&str]); 7] = [
    (
        "heterogeneous",
        "skim milk / skin1 split sphere (.vol), directional light, against its path-traced reference",
        &[
            "--schedule", "cascade",
            "--shape", "sphere", "--size-mm", "20",
            "--volume", "tests/reference/pt/milk-skin-split.vol", "--eta", "1",
            "--light", "dir:0.5,-1,-0.5:4,4,4", "--camera", PT_CAMERA, "--width", "96",
            "--height", "96", "--no-specular",
            "--reference", "tests/reference/pt/split-sphere-dir-eta1.exr", "--resolution", "24,32",
            "--levels", "3", "-K", "1", "--iterations", "2000",
            "--tolerance", "1e-2,3e-3,1e-3,1e-4", "--precision", "mixed,fp32",
            "--start", "cold,warm", "--repeats", "2",
        ],
    ),
    (
        "thin",
        "cheburashka (thin ears), veined marble, back and fill light",
        &[
            "--schedule", "cascade",
            "--mesh", "@MESHES/cheburashka.obj", "--size-mm", "50", "--material", "veined-marble",
            "--width", "128", "--height", "128", "--no-specular", "--resolution", "32",
            "--levels", "3", "-K", "0,1", "--iterations", "2000",
            "--tolerance", "1e-2,1e-3,1e-4", "--precision", "mixed,fp32,fp16",
            "--start", "cold", "--repeats", "2",
        ],
    ),
    (
        "scan",
        "Stanford bunny (a scan with holes), skim milk, back and fill light",
        &[
            "--schedule", "cascade",
            "--mesh", "@MESHES/stanford-bunny.obj", "--size-mm", "50", "--material", "skimmilk",
            "--width", "128", "--height", "128", "--no-specular", "--resolution", "24",
            "--levels", "3", "-K", "1", "--iterations", "16,64,256,1024", "--tolerance", "0",
            "--scheme", "fv,paper", "--start", "cold,warm", "--repeats", "2",
        ],
    ),
    (
        "scan-reference",
        "Stanford bunny lit from the side through its thin ears, marble, against its path-traced reference",
        &[
            "--schedule", "cascade",
            "--mesh", "@MESHES/stanford-bunny.obj", "--size-mm", "20", "--material", "marble",
            "--eta", "1", "--light", "dir:1,-0.2,0:5,5,5", "--camera", PT_CAMERA,
            "--width", "96", "--height", "96", "--no-specular",
            "--reference", "tests/reference/pt/bunny-marble-side-eta1.exr", "--resolution", "24,32",
            "--levels", "3", "-K", "1", "--iterations", "2000",
            "--tolerance", "1e-2,1e-3,1e-4", "--precision", "mixed", "--start", "cold,warm",
            "--repeats", "2",
        ],
    ),
    (
        "sphere-env",
        "marble sphere in a white environment (closed form), against its path-traced reference",
        &[
            "--schedule", "cascade",
            "--shape", "sphere", "--size-mm", "20", "--material", "marble", "--eta", "1.3",
            "--env-constant", "1,1,1", "--light", "dir:0,-1,0:0,0,0", "--camera", PT_CAMERA,
            "--width", "96", "--height", "96",
            "--reference", "tests/reference/pt/marble-sphere-env-eta1.3.exr",
            "--resolution", "16,24,32", "--levels", "3", "-K", "1", "--iterations", "2000",
            "--tolerance", "1e-2,1e-3,1e-4", "--repeats", "2",
        ],
    ),
    (
        "multilevel",
        "paper Fig. 14: one level against three, skin1 sphere (gpu_solve's table)",
        &[
            "--schedule", "cascade",
            "--shape", "sphere", "--size-mm", "20", "--material", "skin1",
            "--light", "dir:-0.3,-1,0.2:1,1,1", "--env-constant", "0.05,0.05,0.05", "--width", "96",
            "--height", "96", "--no-specular", "--resolution", "24", "--levels", "1,3", "-K", "1",
            "--iterations", "2000", "--tolerance", "3e-2,1e-2,3e-3,1e-3,3e-4,1e-4",
            "--repeats", "2",
        ],
    ),
    (
        "schedules",
        "the default scene (torus 50 mm, skim milk, back and fill light): cascade against multigrid, cold and warm",
        &[
            "--shape", "torus", "--size-mm", "50", "--material", "skimmilk", "--width", "256",
            "--height", "256", "--resolution", "48", "--levels", "3", "-K", "1",
            "--iterations", "2000", "--tolerance", "1e-2,1e-3,1e-4",
            "--schedule", "cascade,multigrid", "--start", "cold,warm", "--warm-degrees", "3",
            "--repeats", "1",
        ],
    ),
];

/// Expands a suite into argv (the user's own options after it, so they win).
pub(super) fn suite_args(name: &str) -> Result<Vec<String>, BenchError> {
    let Some((_, _, options)) = SUITES.iter().find(|(n, _, _)| *n == name) else {
        return Err(BenchError::UnknownSuite {
            name: name.to_string(),
            known: suites()
                .map(|(n, d)| format!("{n} ({d})"))
                .collect::<Vec<_>>()
                .join("; "),
        });
    };
    let meshes = std::env::var("TRANSLUCENT_MESH_DIR")
        .ok()
        .filter(|d| !d.is_empty())
        .unwrap_or_else(|| "../shared/meshes".into());
    Ok(options
        .iter()
        .map(|o| o.replace("@MESHES", &meshes))
        .collect())
}

/// The suites: name and what each shows.
pub(super) fn suites() -> impl Iterator<Item = (&'static str, &'static str)> {
    SUITES.iter().map(|(n, d, _)| (*n, *d))
}
