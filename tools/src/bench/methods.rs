//! `translucent bench --method quadgraph,voxel,dipole`: the methods side by side on the
//! path-traced references of `tests/reference/pt` (their README: 96 x 96 px, camera
//! `0,20,60:0,0,0:30`, 20 mm objects). Each method runs at its `render` defaults (QuadGraph: the
//! default bake through the cache and the default solve, cold every frame; voxel: `--voxels auto`,
//! the diffusion model; dipole: the default oracle, hierarchy through the cache), through the same
//! object, headless host, shading and capture. Per scene and method:
//! - `setup_s`: wall seconds before the first frame can be recorded (the bake or its cache load,
//!   the dipole's hierarchy and links, the object's creation and uploads);
//! - `first_frame_s`: wall seconds of the first frame (lavapipe JIT-compiles every pipeline then);
//! - `frame_wall_ms` / `frame_gpu_ms`: the median of `--repeats` later frames, every frame
//!   recomputing everything (skipping off): wall of `HeadlessHost::render` (record, submit, wait,
//!   read back) and the sum of the frame's top-level GPU scopes but the capture copy;
//! - `image_*`: the relative RMS of the image against the reference over the pixels it covers
//!   fully (alpha >= 0.999, as `tools/compare_exr.py`), per channel and over all;
//! - `auto`: what `--method auto`'s rule ([`translucent::frame::choose_method`]) picks there.
//!
//! A method that refuses a scene (the dipole and a heterogeneous material) gets a row with its
//! error message in `note` and no numbers. `auto` in the list runs the rule's pick for each scene.
//! Writes `DIR/methods.csv` and `DIR/methods.png` (two panels: image error against the frame's
//! GPU ms, and against setup + first frame in s; method = colour and marker, the scene's number
//! beside each point).
//!
//! ```text
//! translucent bench --method quadgraph,voxel,dipole --out bench-methods
//! translucent bench --method voxel,dipole --scenes marble-sphere-dir,split-sphere-dir --out m
//! ```

use std::sync::Arc;
use std::time::Instant;

use anyhow::Context as _;
use translucent::frame::{choose_method, DipoleParams, MethodKind, SceneTraits};
use translucent::headless::HeadlessHost;
use translucent::scene::{Environment, Scene};
use translucent::solver::dipole::cache as dipole_cache;
use translucent::vk::capture::write_atomically;
use translucent::vk::{Context, ContextDesc};
use translucent::{MethodDesc, ObjectParams, TranslucentObject};
use translucent_benches::plot::{methods_chart, Labelled, LabelledPanel, Marker, RGBColor};

use super::*;

/// The references: name, what it is, file under `tests/reference/pt`, the options that rebuild
/// its scene (its README's commands; `@MESHES` as for the suites).
#[rustfmt::skip]
pub(super) const REFERENCES: [(&str, &str, &[&str]); 8] = [
    ("skimmilk-sphere-dir", "skimmilk-sphere-dir-eta1.exr",
     &["--shape", "sphere", "--material", "skimmilk", "--eta", "1", "--light", "dir:0.5,-1,-0.5:4,4,4", "--no-specular"]),
    ("marble-sphere-dir", "marble-sphere-dir-eta1.exr",
     &["--shape", "sphere", "--material", "marble", "--eta", "1", "--light", "dir:0.5,-1,-0.5:4,4,4", "--no-specular"]),
    ("marble-sphere-backlit", "marble-sphere-backlit-eta1.exr",
     &["--shape", "sphere", "--material", "marble", "--eta", "1", "--light", "dir:0.2,-0.35,1:5,5,5", "--no-specular"]),
    ("marble-torus-backlit", "marble-torus-backlit-eta1.exr",
     &["--shape", "torus", "--material", "marble", "--eta", "1", "--light", "dir:0.2,-0.35,1:5,5,5", "--no-specular"]),
    ("split-sphere-dir", "split-sphere-dir-eta1.exr",
     &["--shape", "sphere", "--volume", "tests/reference/pt/milk-skin-split.vol", "--eta", "1", "--light", "dir:0.5,-1,-0.5:4,4,4", "--no-specular"]),
    ("marble-sphere-env", "marble-sphere-env-eta1.3.exr",
     &["--shape", "sphere", "--material", "marble", "--eta", "1.3", "--env-constant", "1,1,1", "--light", "dir:0,-1,0:0,0,0"]),
    ("bunny-marble-dir", "bunny-marble-dir-eta1.exr",
     &["--mesh", "@MESHES/stanford-bunny.obj", "--material", "marble", "--eta", "1", "--light", "dir:0.5,-1,-0.5:4,4,4", "--no-specular"]),
    ("bunny-marble-side", "bunny-marble-side-eta1.exr",
     &["--mesh", "@MESHES/stanford-bunny.obj", "--material", "marble", "--eta", "1", "--light", "dir:1,-0.2,0:5,5,5", "--no-specular"]),
];

/// Where the references live (relative to the repository root, as the suites' paths).
const REFERENCE_DIR: &str = "tests/reference/pt";

/// A `--method` item: a method, or the rule's pick per scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum MethodItem {
    Named(MethodKind),
    Auto,
}

pub(super) fn parse_methods(text: &str) -> Result<Vec<MethodItem>, BenchError> {
    list("--method", text, |s| match s {
        "auto" => Ok(MethodItem::Auto),
        _ => s
            .parse::<MethodKind>()
            .map(MethodItem::Named)
            .map_err(|_| "is not a method (quadgraph, voxel, dipole, auto)".to_string()),
    })
}

pub(super) fn parse_scenes(text: Option<&str>) -> Result<Vec<usize>, BenchError> {
    let Some(text) = text else {
        return Ok((0..REFERENCES.len()).collect());
    };
    list("--scenes", text, |s| {
        REFERENCES
            .iter()
            .position(|(n, _, _)| *n == s)
            .ok_or_else(|| {
                format!(
                    "is not a reference scene ({})",
                    REFERENCES.map(|(n, _, _)| n).join(", ")
                )
            })
    })
}

/// One method on one scene.
#[derive(Clone, Debug, Default)]
pub(super) struct MethodRow {
    pub(super) scene: usize,
    pub(super) method: &'static str,
    pub(super) auto: &'static str,
    pub(super) setup_s: Option<f64>,
    pub(super) first_frame_s: Option<f64>,
    pub(super) frame_wall_ms: Option<f64>,
    pub(super) frame_gpu_ms: Option<f64>,
    pub(super) image: Option<Errors>,
    pub(super) gpu_bytes: Option<u64>,
    pub(super) note: String,
}

const CSV_HEADER: &str = "scene,name,method,auto,setup_s,first_frame_s,frame_wall_ms,frame_gpu_ms,image_r,image_g,image_b,image_all,gpu_bytes,note";

impl MethodRow {
    fn csv(&self) -> String {
        let num =
            |v: Option<f64>, digits: usize| v.map_or(String::new(), |v| format!("{v:.digits$}"));
        let errs = self.image.unwrap_or([None; 4]).map(|e| num(e, 5)).join(",");
        format!(
            "{},{},{},{},{},{},{},{},{errs},{},{}",
            self.scene + 1,
            REFERENCES[self.scene].0,
            self.method,
            self.auto,
            num(self.setup_s, 3),
            num(self.first_frame_s, 3),
            num(self.frame_wall_ms, 1),
            num(self.frame_gpu_ms, 1),
            self.gpu_bytes.map_or(String::new(), |b| b.to_string()),
            // The note is free text: no commas or quotes in a cell.
            self.note.replace([',', '"', '\n'], ";"),
        )
    }

    fn summary(&self) -> String {
        let ms = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.1}"));
        format!(
            "{:>2} {:<22} {:<9} setup {:>7} s | first frame {:>7} s | frame {:>8} ms wall, {:>8} ms GPU | image error {} {}",
            self.scene + 1,
            REFERENCES[self.scene].0,
            self.method,
            self.setup_s.map_or("-".into(), |v| format!("{v:.2}")),
            self.first_frame_s.map_or("-".into(), |v| format!("{v:.2}")),
            ms(self.frame_wall_ms),
            ms(self.frame_gpu_ms),
            self.image
                .and_then(|e| e[3])
                .map_or("-".into(), |e| format!("{:.1}%", 100.0 * e)),
            self.note
        )
    }
}

/// The scene's options parsed as bench options (with the references' shared camera and size).
fn scene_args(index: usize, repeats: u32) -> anyhow::Result<BenchArgs> {
    let (name, _, options) = REFERENCES[index];
    let meshes = std::env::var("TRANSLUCENT_MESH_DIR")
        .ok()
        .filter(|d| !d.is_empty())
        .unwrap_or_else(|| "../shared/meshes".into());
    let mut argv: Vec<String> = vec!["translucent bench".into()];
    argv.extend(options.iter().map(|o| o.replace("@MESHES", &meshes)));
    argv.extend(
        [
            "--size-mm",
            "20",
            "--camera",
            PT_CAMERA,
            "--width",
            "96",
            "--height",
            "96",
            "--out",
            "unused",
        ]
        .map(String::from),
    );
    argv.extend(["--repeats".into(), repeats.to_string()]);
    let cli = SuiteCli::try_parse_from(&argv).with_context(|| format!("scene {name}"))?;
    Ok(cli.args)
}

pub(super) fn run(args: &BenchArgs, methods_text: &str) -> anyhow::Result<()> {
    for (given, option) in [
        (args.suite.is_some(), "--suite"),
        (args.mesh.is_some(), "--mesh"),
        (args.shape.is_some(), "--shape"),
        (args.reference.is_some(), "--reference"),
    ] {
        if given {
            return Err(BenchError::BadOption {
                option: "--method",
                problem: format!(
                    "compares the methods on the path-traced references ({REFERENCE_DIR}, choose with --scenes); {option} belongs to the QuadGraph sweep"
                ),
            }
            .into());
        }
    }
    let items = parse_methods(methods_text)?;
    if args.replot {
        return replot_methods(&args.out);
    }
    let scenes = parse_scenes(args.scenes.as_deref())?;
    if args.repeats == 0 {
        return Err(BenchError::BadOption {
            option: "--repeats",
            problem: "0: time at least one frame".into(),
        }
        .into());
    }
    if args.out.exists() && !args.out.is_dir() {
        return Err(BenchError::BadOption {
            option: "--out",
            problem: format!("{} exists and is not a directory", args.out.display()),
        }
        .into());
    }
    let cache_dir = args
        .cache_dir
        .clone()
        .unwrap_or_else(crate::render::default_cache_dir);
    std::fs::create_dir_all(&cache_dir)
        .with_context(|| format!("creating the cache directory {}", cache_dir.display()))?;
    let ctx = Context::headless(&ContextDesc {
        echo_validation: true,
        ..ContextDesc::default()
    })?;
    let mut rows = Vec::new();
    for &scene in &scenes {
        let scene_options = scene_args(scene, args.repeats)?;
        let (name, file, _) = REFERENCES[scene];
        let reference = Reference::load(&std::path::Path::new(REFERENCE_DIR).join(file))?;
        let field = scene_options.material.field(20.0, "skimmilk")?;
        let environment = match &scene_options.env_constant {
            Some(text) => Environment::Constant(rgb("--env-constant", text)?),
            None => Environment::None,
        };
        let lit = Scene {
            lights: scene_options.scene.lights()?,
            environment,
        };
        lit.validate()?;
        let frame_desc = scene_options.scene.frame_desc()?;
        // why: a fixed lattice (the bake's default, 48 cells, not `--resolution auto`) keeps this
        // table comparable with the earlier ones in RESULTS.md.
        let fixed_cells = translucent::quadgraph::BakeParams::default().resolution;
        let object_args = crate::object_args::ObjectArgs {
            mesh: scene_options.mesh.clone(),
            shape: scene_options.shape.clone(),
            size_mm: 20.0,
            k: translucent::quadgraph::BakeParams::default().k,
            levels: crate::object_args::LevelsArg::Count(
                translucent::quadgraph::BakeParams::default().levels,
            ),
            resolution: crate::object_args::ResolutionArg::Cells(fixed_cells),
            // The automatic up axis, as `render` (tools/src/framing.rs).
            up: "auto".into(),
            relax: false,
            force: false,
        };
        let object = object_args
            .load(None)
            .with_context(|| format!("scene {name}"))?;
        let auto = choose_method(&SceneTraits::of(&field, &lit)).kind;
        let mut kinds: Vec<MethodKind> = Vec::new();
        for item in &items {
            let kind = match item {
                MethodItem::Named(k) => *k,
                MethodItem::Auto => auto,
            };
            if !kinds.contains(&kind) {
                kinds.push(kind);
            }
        }
        for kind in kinds {
            let mut row = MethodRow {
                scene,
                method: kind.name(),
                auto: auto.name(),
                ..MethodRow::default()
            };
            let start = Instant::now();
            let desc = match kind {
                MethodKind::QuadGraph => {
                    let (graph, _, _, _) = crate::cache::bake(
                        &object,
                        &object_args.bake_params(&crate::object_args::Resolution {
                            cells: fixed_cells,
                            spacing_mm: 0.0,
                            auto: None,
                        }),
                        Some(&cache_dir),
                    )
                    .with_context(|| format!("scene {name}: bake"))?;
                    MethodDesc::QuadGraph(Arc::new(graph))
                }
                MethodKind::Voxel => MethodDesc::Voxel {
                    mesh: object.surface.clone(),
                    params: crate::render::voxel::voxel_params(None, None, None)?,
                },
                MethodKind::Dipole => {
                    let key = dipole_cache::cache_key(&object.surface);
                    let path = cache_dir.join(format!("{}-{key:016x}.dipole", object.name));
                    let (tree, _, _) = dipole_cache::build_cached(&path, &object.surface)?;
                    MethodDesc::Dipole {
                        mesh: object.surface.clone(),
                        hierarchy: Arc::new(tree),
                        params: DipoleParams::default(),
                    }
                }
            };
            // `render`'s defaults for this method and material (the library's).
            let params = ObjectParams {
                specular: frame_desc.specular,
                roughness: frame_desc.roughness,
                radiance: frame_desc.radiance,
                exit_lobe: frame_desc.exit_lobe,
                skip: false,
                ..translucent::defaults::Settings::for_method(kind, field.is_homogeneous())
                    .object_params()
            };
            match TranslucentObject::with_method(&ctx, desc, &field, &lit, &params) {
                Err(e) => row.note = format!("refused: {e}"),
                Ok(mut translucent) => {
                    row.setup_s = Some(start.elapsed().as_secs_f64());
                    translucent.set_camera(frame_desc.camera)?;
                    let mut host = HeadlessHost::new(&ctx, frame_desc.width, frame_desc.height)?;
                    let (mut wall, mut gpu) = (Vec::new(), Vec::new());
                    let mut last = None;
                    for i in 0..=args.repeats {
                        let t = Instant::now();
                        let (captured, _) = host
                            .render(&ctx, &mut translucent)
                            .with_context(|| format!("scene {name}, {}", kind.name()))?;
                        let seconds = t.elapsed().as_secs_f64();
                        if i == 0 {
                            row.first_frame_s = Some(seconds);
                        } else {
                            wall.push(1e3 * seconds);
                            let timings = captured.timings.as_ref().context(
                                "no GPU timestamps on this device: bench measures GPU time",
                            )?;
                            gpu.push(
                                timings
                                    .scopes
                                    .iter()
                                    .filter(|s| s.depth == 0 && s.name != "capture")
                                    .map(|s| s.duration_ms)
                                    .sum(),
                            );
                        }
                        last = Some(captured);
                    }
                    let last = last.context("no frame rendered")?;
                    if last.image.pixels.iter().flatten().any(|v| !v.is_finite()) {
                        anyhow::bail!("scene {name}, {}: the image is not finite", kind.name());
                    }
                    row.frame_wall_ms = Some(median(wall));
                    row.frame_gpu_ms = Some(median(gpu));
                    row.image = Some(reference.error(&last.image));
                    row.gpu_bytes = Some(translucent.gpu_bytes());
                    drop(host);
                }
            }
            if !args.json {
                println!("{}", row.summary());
            }
            rows.push(row);
        }
    }
    let messages = ctx.take_validation_messages();
    if !messages.is_empty() {
        anyhow::bail!("{} validation message(s) (printed above)", messages.len());
    }
    drop(ctx);

    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let csv_path = args.out.join("methods.csv");
    let mut text = String::from(CSV_HEADER);
    for row in &rows {
        text.push('\n');
        text.push_str(&row.csv());
    }
    text.push('\n');
    write_atomically(&csv_path, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|e| e.to_string())
    })
    .with_context(|| format!("writing {}", csv_path.display()))?;
    let png_path = args.out.join("methods.png");
    write_atomically(&png_path, |tmp| {
        plot_methods(tmp, &rows).map_err(|e| e.to_string())
    })
    .with_context(|| format!("writing {}", png_path.display()))?;
    if args.json {
        let out: Vec<serde_json::Value> = rows
            .iter()
            .map(|r| {
                serde_json::json!({
                    "scene": REFERENCES[r.scene].0,
                    "method": r.method,
                    "auto": r.auto,
                    "setup_s": r.setup_s,
                    "first_frame_s": r.first_frame_s,
                    "frame_wall_ms": r.frame_wall_ms,
                    "frame_gpu_ms": r.frame_gpu_ms,
                    "image_error": r.image.map(|e| e[3]),
                    "gpu_bytes": r.gpu_bytes,
                    "note": r.note,
                })
            })
            .collect();
        println!(
            "{}",
            serde_json::json!({ "rows": out, "csv": csv_path, "png": png_path })
        );
    } else {
        println!("wrote {} and {}", csv_path.display(), png_path.display());
    }
    Ok(())
}

/// `--replot`: redraws `dir/methods.png` from `dir/methods.csv` (nothing runs).
fn replot_methods(dir: &std::path::Path) -> anyhow::Result<()> {
    let csv_path = dir.join("methods.csv");
    let text = std::fs::read_to_string(&csv_path)
        .with_context(|| format!("--replot: reading {}", csv_path.display()))?;
    let mut lines = text.lines();
    if lines.next() != Some(CSV_HEADER) {
        anyhow::bail!("{}: not a methods.csv (header differs)", csv_path.display());
    }
    let mut rows = Vec::new();
    for (n, line) in lines.enumerate() {
        let bad = || anyhow::anyhow!("{} line {}: malformed", csv_path.display(), n + 2);
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != CSV_HEADER.split(',').count() {
            return Err(bad());
        }
        let number = |i: usize| -> anyhow::Result<Option<f64>> {
            match cells[i] {
                "" => Ok(None),
                v => v.parse::<f64>().map(Some).map_err(|_| bad()),
            }
        };
        let scene = cells[0]
            .parse::<usize>()
            .ok()
            .filter(|s| (1..=REFERENCES.len()).contains(s))
            .ok_or_else(bad)?
            - 1;
        let method = ["quadgraph", "voxel", "dipole"]
            .into_iter()
            .find(|m| *m == cells[2])
            .ok_or_else(bad)?;
        rows.push(MethodRow {
            scene,
            method,
            setup_s: number(4)?,
            first_frame_s: number(5)?,
            frame_wall_ms: number(6)?,
            frame_gpu_ms: number(7)?,
            image: number(11)?.map(|e| [None, None, None, Some(e)]),
            ..MethodRow::default()
        });
    }
    let png_path = dir.join("methods.png");
    write_atomically(&png_path, |tmp| {
        plot_methods(tmp, &rows).map_err(|e| e.to_string())
    })
    .with_context(|| format!("writing {}", png_path.display()))?;
    println!("wrote {}", png_path.display());
    Ok(())
}

/// The colour and marker of a method on the chart.
fn style(method: &str) -> (RGBColor, Marker) {
    match method {
        "quadgraph" => (RGBColor(31, 119, 180), Marker::Circle),
        "voxel" => (RGBColor(230, 120, 20), Marker::Triangle),
        "dipole" => (RGBColor(44, 160, 44), Marker::Square),
        _ => (RGBColor(120, 120, 120), Marker::Cross),
    }
}

/// Two panels: image error against the frame's GPU ms and against setup + first frame (s).
pub(super) fn plot_methods(
    path: &std::path::Path,
    rows: &[MethodRow],
) -> Result<(), Box<dyn std::error::Error>> {
    let mut names: Vec<&'static str> = Vec::new();
    for r in rows {
        if !names.contains(&r.method) {
            names.push(r.method);
        }
    }
    type TimeOf = fn(&MethodRow) -> Option<f64>;
    let panels: [(&str, &str, TimeOf); 2] = [
        (
            "per frame, all recomputed",
            "frame GPU time (ms, lavapipe)",
            |r| r.frame_gpu_ms,
        ),
        ("to the first image", "setup + first frame (s, wall)", |r| {
            Some(r.setup_s? + r.first_frame_s?)
        }),
    ];
    let panels: Vec<LabelledPanel> = panels
        .iter()
        .map(|(title, x_title, time)| LabelledPanel {
            title: title.to_string(),
            x_title: x_title.to_string(),
            y_title: "relative RMS error vs path tracing".into(),
            series: names
                .iter()
                .map(|&m| {
                    let (colour, marker) = style(m);
                    Labelled {
                        name: m.to_string(),
                        colour,
                        marker,
                        points: rows
                            .iter()
                            .filter(|r| r.method == m)
                            .filter_map(|r| {
                                Some((time(r)?, r.image?[3]?, (r.scene + 1).to_string()))
                            })
                            .collect(),
                    }
                })
                .collect(),
        })
        .collect();
    methods_chart(path, &panels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn methods_and_scenes_parse_and_bad_names_are_typed_errors() {
        assert_eq!(
            parse_methods("quadgraph, dipole,auto").expect("ok"),
            [
                MethodItem::Named(MethodKind::QuadGraph),
                MethodItem::Named(MethodKind::Dipole),
                MethodItem::Auto
            ]
        );
        let e = parse_methods("voxel,photon").expect_err("unknown method");
        assert!(
            matches!(&e, BenchError::BadList { option: "--method", item, .. } if item == "photon"),
            "{e}"
        );
        assert_eq!(parse_scenes(None).expect("all").len(), REFERENCES.len());
        assert_eq!(parse_scenes(Some("split-sphere-dir")).expect("one"), [4]);
        let e = parse_scenes(Some("marble")).expect_err("unknown scene");
        assert!(e.to_string().contains("marble-sphere-dir"), "{e}");
    }

    #[test]
    fn every_reference_scene_parses_and_its_file_exists() {
        for (i, (name, file, _)) in REFERENCES.iter().enumerate() {
            let args = scene_args(i, 1).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(args.scene.lights().is_ok(), "{name}");
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("..")
                .join(REFERENCE_DIR)
                .join(file);
            assert!(path.is_file(), "{}", path.display());
        }
    }
}
