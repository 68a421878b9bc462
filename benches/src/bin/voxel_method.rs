//! The voxel method (issue 14, phase 1) measured for `benches/RESULTS.md`, "Voxel method":
//!
//! ```text
//! cargo run --release -p translucent-benches --bin voxel_method -- compare [OUT_DIR]
//! cargo run --release -p translucent-benches --bin voxel_method -- timings [FRAMES]
//! cargo run --release -p translucent-benches --bin voxel_method -- render SCENE CONFIG OUT.png
//! ```
//! - `compare`: every committed path-traced reference (`tests/reference/pt/`, same scene, camera
//!   and 96 x 96 px) rendered through `render::HeadlessRenderer` with the voxel method's
//!   per-vertex exitance, for each model configuration; relative RMS over the pixels the object
//!   covers fully (the metric of `tools/compare_exr.py`); writes each image as PNG and EXR under
//!   OUT_DIR (default `target/voxel-compare`) and prints a markdown table.
//! - `timings`: per-pass GPU milliseconds (median over FRAMES frames after one warm-up frame,
//!   lavapipe compiles each pipeline at its first dispatch), iterations and memory at a few
//!   resolutions, Jacobi and sweeping.
//! - `render`: one scene of `compare` with one configuration, written to OUT.png (+ .exr).
//!
//! Meshes from `$TRANSLUCENT_MESH_DIR` (default `../shared/meshes`); run from the repository root.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::DVec3;
use translucent::frame::voxel::VoxelReport;
use translucent::frame::VoxelMethod;
use translucent::headless::HeadlessHost;
use translucent::material::{Material, MaterialField, VolGrid};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{TriMesh, ValidateOptions};
use translucent::scene::{Camera, Environment, Light, Scene};
use translucent::solver::voxel::{Relaxation, VoxelModel, VoxelParams, VoxelResolution};
use translucent::vk::{Context, ContextDesc, LinearImage};
use translucent::{MethodDesc, ObjectParams, TranslucentObject};

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

const SIZE: u32 = 96;

/// A committed reference scene (tests/reference/pt/README.md).
struct RefScene {
    name: &'static str,
    file: &'static str,
    shape: &'static str,
    material: &'static str,
    eta: f64,
    light: Option<&'static str>,
    env: Option<[f64; 3]>,
}

const SCENES: [RefScene; 8] = [
    RefScene {
        name: "milk sphere dir",
        file: "skimmilk-sphere-dir-eta1.exr",
        shape: "sphere",
        material: "skimmilk",
        eta: 1.0,
        light: Some("dir:0.5,-1,-0.5:4,4,4"),
        env: None,
    },
    RefScene {
        name: "marble sphere dir",
        file: "marble-sphere-dir-eta1.exr",
        shape: "sphere",
        material: "marble",
        eta: 1.0,
        light: Some("dir:0.5,-1,-0.5:4,4,4"),
        env: None,
    },
    RefScene {
        name: "marble sphere back-lit",
        file: "marble-sphere-backlit-eta1.exr",
        shape: "sphere",
        material: "marble",
        eta: 1.0,
        light: Some("dir:0.2,-0.35,1:5,5,5"),
        env: None,
    },
    RefScene {
        name: "marble torus back-lit",
        file: "marble-torus-backlit-eta1.exr",
        shape: "torus",
        material: "marble",
        eta: 1.0,
        light: Some("dir:0.2,-0.35,1:5,5,5"),
        env: None,
    },
    RefScene {
        name: "split sphere (.vol) dir",
        file: "split-sphere-dir-eta1.exr",
        shape: "sphere",
        material: "vol",
        eta: 1.0,
        light: Some("dir:0.5,-1,-0.5:4,4,4"),
        env: None,
    },
    RefScene {
        name: "marble sphere env eta 1.3",
        file: "marble-sphere-env-eta1.3.exr",
        shape: "sphere",
        material: "marble",
        eta: 1.3,
        light: None,
        env: Some([1.0; 3]),
    },
    RefScene {
        name: "bunny dir",
        file: "bunny-marble-dir-eta1.exr",
        shape: "bunny",
        material: "marble",
        eta: 1.0,
        light: Some("dir:0.5,-1,-0.5:4,4,4"),
        env: None,
    },
    RefScene {
        name: "bunny side (thin ears)",
        file: "bunny-marble-side-eta1.exr",
        shape: "bunny",
        material: "marble",
        eta: 1.0,
        light: Some("dir:1,-0.2,0:5,5,5"),
        env: None,
    },
];

fn workspace() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default()
}

fn mesh_dir() -> PathBuf {
    std::env::var_os("TRANSLUCENT_MESH_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace().join("../shared/meshes"))
}

/// The display mesh of a scene, 20 mm (as `translucent render --size-mm 20`).
fn mesh(shape: &str, size_mm: f64) -> Result<TriMesh> {
    Ok(match shape {
        "sphere" => Shape::Sphere {
            radius: size_mm / 2.0,
        }
        .triangulate(96),
        "torus" => Shape::Torus {
            major: 0.35 * size_mm,
            minor: 0.15 * size_mm,
        }
        .triangulate(96),
        file => {
            let mut m = TriMesh::load_obj(
                mesh_dir().join(format!("{file}.obj").replace("bunny.obj", "stanford-bunny.obj")),
            )?;
            m.validate(&ValidateOptions::default())?;
            m.normalized(size_mm)?.0
        }
    })
}

fn field(material: &str, eta: f64) -> Result<MaterialField> {
    Ok(if material == "vol" {
        MaterialField::grid(
            VolGrid::read(&workspace().join("tests/reference/pt/milk-skin-split.vol"))?,
            eta,
        )?
    } else {
        let m = Material::preset(material)?;
        MaterialField::Homogeneous(Material::new(m.sigma_s, m.sigma_a, eta)?)
    })
}

/// A reference: (rgb, alpha) per pixel.
fn reference(file: &str) -> Result<Vec<([f32; 3], f32)>> {
    let path = workspace().join("tests/reference/pt").join(file);
    let image = exr::prelude::read_first_rgba_layer_from_file(
        &path,
        |res, _| {
            (
                res.width(),
                vec![([0.0f32; 3], 0.0f32); res.width() * res.height()],
            )
        },
        |(w, buf), pos, (r, g, b, a): (f32, f32, f32, f32)| {
            buf[pos.y() * *w + pos.x()] = ([r, g, b], a)
        },
    )?;
    Ok(image.layer_data.channel_data.pixels.1)
}

/// Relative RMS over the fully covered pixels (tools/compare_exr.py's metric), and the ratio of
/// our mean to the reference's there (brightness).
fn relative_rms(ours: &LinearImage, reference: &[([f32; 3], f32)]) -> (f64, f64) {
    let (mut err, mut norm, mut sum_o, mut sum_r) = (0.0, 0.0, 0.0, 0.0);
    for (o, (r, a)) in ours.pixels.iter().zip(reference) {
        if *a >= 0.999 {
            for c in 0..3 {
                err += (f64::from(o[c]) - f64::from(r[c])).powi(2);
                norm += f64::from(r[c]).powi(2);
                sum_o += f64::from(o[c]);
                sum_r += f64::from(r[c]);
            }
        }
    }
    ((err / norm).sqrt(), sum_o / sum_r)
}

/// One configuration of the method.
#[derive(Clone)]
struct Config {
    name: String,
    params: VoxelParams,
}

fn configs() -> Vec<Config> {
    let p = |model, beta: f32| VoxelParams {
        resolution: VoxelResolution::Auto,
        model,
        soft_beta: beta,
        ..VoxelParams::default()
    };
    vec![
        Config {
            name: "paper".into(),
            params: p(VoxelModel::Paper, 0.0),
        },
        Config {
            name: "paper soft 0.25".into(),
            params: p(VoxelModel::Paper, 0.25),
        },
        Config {
            name: "diffusion".into(),
            params: p(VoxelModel::Diffusion, 0.0),
        },
        Config {
            name: "diffusion soft 0.1".into(),
            params: p(VoxelModel::Diffusion, 0.1),
        },
        Config {
            name: "diffusion soft 0.25".into(),
            params: p(VoxelModel::Diffusion, 0.25),
        },
    ]
}

struct Rendered {
    image: LinearImage,
    passes: BTreeMap<String, f64>,
    iterations: u32,
    converged: bool,
    voxels: u32,
}

/// One frame of the voxel method through the object and the headless host (the frame graph,
/// the shared shading and capture), as `translucent render --method voxel` draws it.
fn render_object(
    ctx: &Context,
    mesh: &TriMesh,
    field: &MaterialField,
    scene: &Scene,
    params: &VoxelParams,
    camera: Option<Camera>,
    frames: usize,
) -> Result<(Vec<Rendered>, VoxelReport)> {
    let mut object = TranslucentObject::with_method(
        ctx,
        MethodDesc::Voxel {
            mesh: mesh.clone(),
            params: params.clone(),
        },
        field,
        scene,
        &ObjectParams {
            // Every frame records the whole method (for timings).
            skip: false,
            ..ObjectParams::default()
        },
    )?;
    object.set_camera(camera)?;
    let mut host = HeadlessHost::new(ctx, SIZE, SIZE)?;
    let mut out = Vec::new();
    for _ in 0..frames {
        let (captured, _) = host.render(ctx, &mut object)?;
        let solves = host.completed_solves(ctx, &mut object)?;
        let (iterations, converged) = solves
            .last()
            .map_or((0, false), |s| (s.iterations()[0], s.converged()));
        out.push(Rendered {
            image: captured.image,
            passes: captured.passes,
            iterations,
            converged,
            voxels: 0,
        });
    }
    let method = object
        .method()
        .as_any()
        .downcast_ref::<VoxelMethod>()
        .ok_or("not the voxel method")?;
    let report = method.passes().report(ctx)?;
    for r in &mut out {
        r.voxels = report.voxels;
    }
    Ok((out, report))
}

fn render(ctx: &Context, scene: &RefScene, params: &VoxelParams) -> Result<Rendered> {
    let mesh = mesh(scene.shape, 20.0)?;
    let field = field(scene.material, scene.eta)?;
    let lights: Vec<Light> = scene
        .light
        .map(|l| l.parse())
        .transpose()?
        .into_iter()
        .collect();
    let environment = scene.env.map_or(Environment::None, Environment::Constant);
    let camera = Camera {
        eye: DVec3::new(0.0, 20.0, 60.0),
        target: DVec3::ZERO,
        fovy_deg: 30.0,
    };
    let (mut frames, _) = render_object(
        ctx,
        &mesh,
        &field,
        &Scene {
            lights,
            environment,
        },
        params,
        Some(camera),
        1,
    )?;
    Ok(frames.remove(0))
}

fn compare(ctx: &Context, out: &Path) -> Result<()> {
    std::fs::create_dir_all(out)?;
    let configs = configs();
    println!(
        "| scene | {} |",
        configs
            .iter()
            .map(|c| c.name.as_str())
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!("|---|{}", "---|".repeat(configs.len()));
    let mut totals = vec![0.0; configs.len()];
    for scene in &SCENES {
        let Ok(reference) = reference(scene.file) else {
            eprintln!("skipped {}: no reference", scene.name);
            continue;
        };
        let mut row = Vec::new();
        for (i, config) in configs.iter().enumerate() {
            let r = match render(ctx, scene, &config.params) {
                Ok(r) => r,
                Err(e) => {
                    eprintln!("{} / {}: {e}", scene.name, config.name);
                    row.push("error".to_string());
                    continue;
                }
            };
            let (rms, ratio) = relative_rms(&r.image, &reference);
            totals[i] += rms;
            let stem = format!(
                "{}-{}",
                scene.file.trim_end_matches(".exr"),
                config.name.replace([' ', ','], "-")
            );
            r.image.write_png(&out.join(format!("{stem}.png")), 1.0)?;
            r.image.write_exr(&out.join(format!("{stem}.exr")))?;
            eprintln!(
                "{} / {}: {:.1}% (mean x{ratio:.2}), N = {}, {} iterations{}",
                scene.name,
                config.name,
                100.0 * rms,
                r.voxels,
                r.iterations,
                if r.converged { "" } else { " (cap)" }
            );
            row.push(format!("{:.1}% (x{ratio:.2})", 100.0 * rms));
        }
        println!("| {} | {} |", scene.name, row.join(" | "));
    }
    println!(
        "| mean | {} |",
        totals
            .iter()
            .map(|t| format!("{:.1}%", 100.0 * t / SCENES.len() as f64))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    Ok(())
}

/// Ours | the reference, 3x enlarged, tone-mapped as `translucent render`'s PNGs.
fn side_by_side(ours: &LinearImage, reference: &[([f32; 3], f32)], out: &Path) -> Result<()> {
    const SCALE: u32 = 3;
    let theirs = LinearImage {
        width: ours.width,
        height: ours.height,
        pixels: reference
            .iter()
            .map(|(c, a)| [c[0], c[1], c[2], *a])
            .collect(),
    };
    let (a, b) = (ours.to_srgb8(1.0), theirs.to_srgb8(1.0));
    let (w, h) = (ours.width, ours.height);
    let mut img = image::RgbImage::new(2 * w * SCALE, h * SCALE);
    for (x, y, p) in img.enumerate_pixels_mut() {
        let (side, sx, sy) = ((x / SCALE) / w, (x / SCALE) % w, y / SCALE);
        let src = if side == 0 { &a } else { &b };
        let i = 3 * (sy * w + sx) as usize;
        *p = image::Rgb([src[i], src[i + 1], src[i + 2]]);
    }
    img.save(out)?;
    Ok(())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

fn timings(ctx: &Context, frames: usize) -> Result<()> {
    println!("| scene | N | dims | relaxation | model | voxelize | rsm | inject | relax | exit | total | iterations | MB |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let light: Light = "dir:0.5,-1,-0.5:4,4,4".parse()?;
    for (name, shape, size) in [("marble sphere", "sphere", 20.0), ("bunny", "bunny", 50.0)] {
        let mesh = mesh(shape, size)?;
        let field = field("marble", 1.0)?;
        for n in [32u32, 64, 96] {
            for (relaxation, model) in [
                (Relaxation::Jacobi, VoxelModel::Paper),
                (Relaxation::Sweep, VoxelModel::Paper),
                (Relaxation::Jacobi, VoxelModel::Diffusion),
            ] {
                let params = VoxelParams {
                    resolution: VoxelResolution::Fixed(n),
                    relaxation,
                    model,
                    ..VoxelParams::default()
                };
                let scene = Scene {
                    lights: vec![light],
                    environment: Environment::None,
                };
                // One warm-up frame (lavapipe compiles each pipeline at its first dispatch).
                let (rendered, report) =
                    render_object(ctx, &mesh, &field, &scene, &params, None, frames + 1)?;
                let mut per_pass: BTreeMap<String, Vec<f64>> = BTreeMap::new();
                for r in &rendered[1..] {
                    for (pass, ms) in &r.passes {
                        per_pass.entry(pass.clone()).or_default().push(*ms);
                    }
                }
                let ms = |p: &str| median(per_pass.get(p).cloned().unwrap_or_default());
                let passes = [
                    "voxelize",
                    "rsm",
                    "voxel inject",
                    "voxel relax",
                    "voxel exit",
                ];
                let total: f64 = passes.iter().map(|p| ms(p)).sum();
                println!(
                    "| {name} | {n} | {}x{}x{} | {relaxation:?} | {model:?} | {} | {:.1} | {} | {:.1} |",
                    report.dims[0],
                    report.dims[1],
                    report.dims[2],
                    passes
                        .iter()
                        .map(|p| format!("{:.1}", ms(p)))
                        .collect::<Vec<_>>()
                        .join(" | "),
                    total,
                    report.iterations,
                    report.bytes as f64 / 1e6,
                );
            }
        }
    }
    Ok(())
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let ctx = Context::headless(&ContextDesc::default())?;
    eprintln!("device: {}", ctx.info().device_name);
    match args.first().map(String::as_str) {
        Some("compare") => compare(
            &ctx,
            &args
                .get(1)
                .map(PathBuf::from)
                .unwrap_or_else(|| workspace().join("target/voxel-compare")),
        ),
        Some("timings") => timings(&ctx, args.get(1).map_or(Ok(5), |s| s.parse())?),
        Some("render") => {
            let (Some(scene), Some(config), Some(out)) = (args.get(1), args.get(2), args.get(3))
            else {
                return Err("render SCENE_FILE CONFIG_NAME OUT.png".into());
            };
            let scene = SCENES
                .iter()
                .find(|s| s.file.starts_with(scene.as_str()))
                .ok_or("unknown scene (a prefix of a reference file name)")?;
            let config = configs()
                .into_iter()
                .find(|c| &c.name == config)
                .ok_or("unknown config")?;
            let r = render(&ctx, scene, &config.params)?;
            let reference = reference(scene.file)?;
            let (rms, ratio) = relative_rms(&r.image, &reference);
            println!("{:.1}% (mean x{ratio:.2}) {:?}", 100.0 * rms, r.passes);
            side_by_side(&r.image, &reference, Path::new(out))
        }
        _ => Err("usage: voxel_method compare [OUT_DIR] | timings [FRAMES] | render SCENE CONFIG OUT.png".into()),
    }
}
