//! Diffusion against the path-traced references with each transport term on and off (issue 12,
//! `benches/RESULTS.md`, "Accuracy: transport terms against path tracing"): for every committed
//! reference of `tests/reference/pt/` the f64 CPU reference solve (exact on the finest level,
//! ray-cast shadows), shaded per display vertex by the headless mesh pass at the reference's
//! camera and size, and the relative RMS over the pixels the object covers fully (the metric of
//! `tools/compare_exr.py`).
//!
//! ```text
//! cargo run --release -p translucent-benches --bin accuracy -- [--resolution 48] [--scenes a,b]
//!     [--variants classic,collimated,...] [--out DIR] [--ss-samples 16] [--bounce-rays 64]
//! ```
//! Variants are named presets or `key=value` lists joined by `/` (exit=classic|moments,
//! source=flux|collimated|second, ss=off|diff|full, surface=shepard|depth, bounce=N, cont=0|1,
//! thin=MFP). `--out DIR` writes each image as `DIR/SCENE-VARIANT.exr`. Prints one markdown row
//! per scene: per variant R, G, B (all) in %. Also per scene, for the depth-sampled surface,
//! the coefficient of variation of the per-vertex exitance where the exact one is constant
//! (environment-lit spheres). `TRANSLUCENT_DEVICE` picks the Vulkan device (lavapipe in CI).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::DVec3;
use translucent::headless::{ExitanceMesh, FrameDesc, HeadlessRenderer};
use translucent::material::{Material, MaterialField, VolGrid};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, Solid, TriMesh, ValidateOptions};
use translucent::quadgraph::{cache, BakeParams};
use translucent::scene::{Camera, Environment, Light, RadianceMode, Scene};
use translucent::solver::single_scattering::vertex_single_scattering;
use translucent::solver::transport::{
    ExitQuery, SingleScattering, Source, SurfaceReconstruction, Transport,
};
use translucent::solver::{self, CpuSolveParams};
use translucent::vk::{Context, ContextDesc};
use translucent::QuadGraph;

type Result<T> = std::result::Result<T, Box<dyn std::error::Error>>;

/// The references' camera and size (tests/reference/pt/README.md).
const EYE: DVec3 = DVec3::new(0.0, 20.0, 60.0);
const FOVY: f64 = 30.0;

struct SceneSpec {
    name: &'static str,
    reference: &'static str,
    object: &'static str,
    size_mm: f64,
    material: &'static str,
    eta: f64,
    lights: &'static [&'static str],
    env: Option<f64>,
}

const FRONT: &str = "dir:0.5,-1,-0.5:4,4,4";
const BACK: &str = "dir:0.2,-0.35,1:5,5,5";

const SCENES: &[SceneSpec] = &[
    SceneSpec {
        name: "milk-sphere",
        reference: "skimmilk-sphere-dir-eta1.exr",
        object: "sphere",
        size_mm: 20.0,
        material: "skimmilk",
        eta: 1.0,
        lights: &[FRONT],
        env: None,
    },
    SceneSpec {
        name: "marble-sphere",
        reference: "marble-sphere-dir-eta1.exr",
        object: "sphere",
        size_mm: 20.0,
        material: "marble",
        eta: 1.0,
        lights: &[FRONT],
        env: None,
    },
    SceneSpec {
        name: "split-sphere",
        reference: "split-sphere-dir-eta1.exr",
        object: "sphere",
        size_mm: 20.0,
        material: "vol:milk-skin-split.vol",
        eta: 1.0,
        lights: &[FRONT],
        env: None,
    },
    SceneSpec {
        name: "bunny-front",
        reference: "bunny-marble-dir-eta1.exr",
        object: "mesh:stanford-bunny.obj",
        size_mm: 20.0,
        material: "marble",
        eta: 1.0,
        lights: &[FRONT],
        env: None,
    },
    SceneSpec {
        name: "marble-sphere-back",
        reference: "marble-sphere-backlit-eta1.exr",
        object: "sphere",
        size_mm: 20.0,
        material: "marble",
        eta: 1.0,
        lights: &[BACK],
        env: None,
    },
    SceneSpec {
        name: "torus-back",
        reference: "marble-torus-backlit-eta1.exr",
        object: "torus",
        size_mm: 20.0,
        material: "marble",
        eta: 1.0,
        lights: &[BACK],
        env: None,
    },
    SceneSpec {
        name: "bunny-side",
        reference: "bunny-marble-side-eta1.exr",
        object: "mesh:stanford-bunny.obj",
        size_mm: 20.0,
        material: "marble",
        eta: 1.0,
        lights: &["dir:1,-0.2,0:5,5,5"],
        env: None,
    },
    SceneSpec {
        name: "plate-back",
        reference: "marble-plate-backlit-eta1.exr",
        object: "ref:plate-on-base.obj",
        size_mm: 30.0,
        material: "marble",
        eta: 1.0,
        lights: &[BACK],
        env: None,
    },
    SceneSpec {
        name: "u-front",
        reference: "marble-u-front-eta1.exr",
        object: "ref:u-block.obj",
        size_mm: 20.0,
        material: "marble",
        eta: 1.0,
        lights: &[FRONT],
        env: None,
    },
    SceneSpec {
        name: "u-back",
        reference: "marble-u-backlit-eta1.exr",
        object: "ref:u-block.obj",
        size_mm: 20.0,
        material: "marble",
        eta: 1.0,
        lights: &[BACK],
        env: None,
    },
    SceneSpec {
        name: "marble-env",
        reference: "marble-sphere-env-eta1.3.exr",
        object: "sphere",
        size_mm: 20.0,
        material: "marble",
        eta: 1.3,
        lights: &[],
        env: Some(1.0),
    },
    SceneSpec {
        name: "skin1-env",
        reference: "skin1-sphere-env-eta1.3.exr",
        object: "sphere",
        size_mm: 20.0,
        material: "skin1",
        eta: 1.3,
        lights: &[],
        env: Some(1.0),
    },
    SceneSpec {
        name: "ketchup-env",
        reference: "ketchup-sphere-env-eta1.3.exr",
        object: "sphere",
        size_mm: 20.0,
        material: "ketchup",
        eta: 1.3,
        lights: &[],
        env: Some(1.0),
    },
];

/// A named preset or a `key=value/...` list.
fn parse_variant(spec: &str, bounce_rays: u32) -> Result<Transport> {
    let preset = match spec {
        "classic" => Some(Transport::default()),
        "classic-depth" => Some(Transport {
            surface: SurfaceReconstruction::DepthSample,
            ..Transport::default()
        }),
        "moments" => Some(Transport {
            exit: ExitQuery::Moments,
            ..Transport::default()
        }),
        "collimated" => Some(Transport {
            single_scattering: SingleScattering::Off,
            ..Transport::collimated()
        }),
        "collimated-ss" => Some(Transport::collimated()),
        "second" => Some(Transport::second_collision()),
        "second-shepard" => Some(Transport {
            surface: SurfaceReconstruction::Shepard,
            ..Transport::second_collision()
        }),
        "second-bounce" => Some(Transport {
            bounce_rays,
            ..Transport::second_collision()
        }),
        _ => None,
    };
    if let Some(t) = preset {
        return Ok(t);
    }
    let mut t = Transport::default();
    for kv in spec.split('/') {
        let (k, v) = kv
            .split_once('=')
            .ok_or_else(|| format!("variant {spec}: {kv} is not key=value"))?;
        match (k, v) {
            ("exit", "classic") => t.exit = ExitQuery::Classic,
            ("exit", "moments") => t.exit = ExitQuery::Moments,
            ("source", "flux") => t.source = Source::BoundaryFlux,
            ("source", "collimated") => t.source = Source::Collimated,
            ("source", "second") => t.source = Source::SecondCollision,
            ("ss", "off") => t.single_scattering = SingleScattering::Off,
            ("ss", "diff") => t.single_scattering = SingleScattering::Difference,
            ("ss", "full") => t.single_scattering = SingleScattering::Full,
            ("surface", "shepard") => t.surface = SurfaceReconstruction::Shepard,
            ("surface", "depth") => t.surface = SurfaceReconstruction::DepthSample,
            ("bounce", n) => t.bounce_rays = n.parse()?,
            ("cont", n) => t.continuation = n != "0",
            ("thin", x) => t.thin_wall_mfp = x.parse()?,
            _ => return Err(format!("variant {spec}: unknown {kv}").into()),
        }
    }
    Ok(t)
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn mesh_dir() -> PathBuf {
    std::env::var_os("TRANSLUCENT_MESH_DIR")
        .map_or_else(|| repo().join("../shared/meshes"), PathBuf::from)
}

/// The display surface and the solid of a scene's object, normalized to `size_mm`.
fn object(spec: &SceneSpec) -> Result<(TriMesh, Box<dyn Solid>)> {
    let shape =
        |s: Shape| -> Result<(TriMesh, Box<dyn Solid>)> { Ok((s.triangulate(96), Box::new(s))) };
    match spec.object {
        "sphere" => shape(Shape::Sphere {
            radius: 0.5 * spec.size_mm,
        }),
        "torus" => shape(Shape::Torus {
            major: 0.35 * spec.size_mm,
            minor: 0.15 * spec.size_mm,
        }),
        other => {
            let path = if let Some(file) = other.strip_prefix("mesh:") {
                mesh_dir().join(file)
            } else if let Some(file) = other.strip_prefix("ref:") {
                // Generated, never committed: `python3 tests/reference/pt/make_shapes.py`.
                let path = repo().join("target/pt-shapes").join(file);
                if !path.exists() {
                    return Err(format!(
                        "{}: run python3 tests/reference/pt/make_shapes.py first",
                        path.display()
                    )
                    .into());
                }
                path
            } else {
                return Err(format!("unknown object {other}").into());
            };
            let (solid, _, _) = MeshSolid::load(&path, spec.size_mm, &ValidateOptions::default())?;
            let surface = solid.mesh().clone();
            Ok((surface, Box::new(solid)))
        }
    }
}

fn material(spec: &SceneSpec) -> Result<MaterialField> {
    if let Some(file) = spec.material.strip_prefix("vol:") {
        let grid = VolGrid::read(&repo().join("tests/reference/pt").join(file))?;
        return Ok(MaterialField::grid(grid, spec.eta)?);
    }
    let m = Material::preset(spec.material)?;
    Ok(MaterialField::Homogeneous(Material::new(
        m.sigma_s, m.sigma_a, spec.eta,
    )?))
}

/// A reference image: (rgb, alpha) per pixel, row 0 at the top, and its width.
/// Per pixel: linear RGB and coverage (alpha).
type Pixels = Vec<([f32; 3], f32)>;

fn reference(name: &str) -> Result<(usize, Pixels)> {
    let path = repo().join("tests/reference/pt").join(name);
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
    let (w, pixels) = image.layer_data.channel_data.pixels;
    Ok((w, pixels))
}

/// Relative RMS over the fully covered pixels: (per channel, all).
fn relative_rms(ours: &[[f32; 4]], reference: &[([f32; 3], f32)]) -> ([f64; 3], f64) {
    let (mut err, mut norm) = ([0.0f64; 3], [0.0f64; 3]);
    for (o, (r, a)) in ours.iter().zip(reference) {
        if *a >= 0.999 {
            for c in 0..3 {
                err[c] += (f64::from(o[c]) - f64::from(r[c])).powi(2);
                norm[c] += f64::from(r[c]).powi(2);
            }
        }
    }
    let per = std::array::from_fn(|c| (err[c] / norm[c].max(1e-300)).sqrt());
    (
        per,
        (err.iter().sum::<f64>() / norm.iter().sum::<f64>().max(1e-300)).sqrt(),
    )
}

struct Args {
    resolution: u32,
    scenes: Option<Vec<String>>,
    variants: Vec<String>,
    out: Option<PathBuf>,
    ss_samples: usize,
    bounce_rays: u32,
}

fn parse_args() -> Result<Args> {
    let mut args = Args {
        resolution: BakeParams::default().resolution,
        scenes: None,
        variants: [
            "classic",
            "collimated",
            "collimated-ss",
            "second",
            "second-bounce",
        ]
        .map(String::from)
        .to_vec(),
        out: None,
        ss_samples: 16,
        bounce_rays: 64,
    };
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        let mut value = || it.next().ok_or_else(|| format!("{a}: missing value"));
        match a.as_str() {
            "--resolution" => args.resolution = value()?.parse()?,
            "--scenes" => args.scenes = Some(value()?.split(',').map(String::from).collect()),
            "--variants" => args.variants = value()?.split(',').map(String::from).collect(),
            "--out" => args.out = Some(value()?.into()),
            "--ss-samples" => args.ss_samples = value()?.parse()?,
            "--bounce-rays" => args.bounce_rays = value()?.parse()?,
            other => return Err(format!("unknown argument {other}").into()),
        }
    }
    Ok(args)
}

fn main() -> Result<()> {
    let args = parse_args()?;
    let ctx = Context::headless(&ContextDesc::default())?;
    let cache_dir = std::env::var_os("TRANSLUCENT_CACHE_DIR")
        .map_or_else(|| repo().join("target/accuracy-cache"), PathBuf::from);
    std::fs::create_dir_all(&cache_dir)?;
    if let Some(out) = &args.out {
        std::fs::create_dir_all(out)?;
    }
    println!(
        "resolution {}, variants {}",
        args.resolution,
        args.variants.join(", ")
    );
    println!("| scene | {} |", args.variants.join(" | "));
    println!("|---|{}", "---|".repeat(args.variants.len()));
    for spec in SCENES {
        if args
            .scenes
            .as_ref()
            .is_some_and(|s| !s.iter().any(|n| n == spec.name))
        {
            continue;
        }
        let Ok((width, reference)) = reference(spec.reference) else {
            eprintln!("{}: no reference {} (skipped)", spec.name, spec.reference);
            continue;
        };
        let (surface, solid) = object(spec)?;
        let params = BakeParams {
            resolution: args.resolution,
            ..BakeParams::default()
        };
        let key = cache::cache_key(&surface, &params);
        let file = cache_dir.join(format!("{}-{key:016x}.qgraph", spec.name));
        let (graph, _, _) =
            cache::bake_cached(&file, &surface, solid.as_ref(), &params, &mut |_| {})?;
        let field = material(spec)?;
        let lights: Vec<Light> = spec
            .lights
            .iter()
            .map(|l| l.parse())
            .collect::<std::result::Result<_, _>>()?;
        let environment = spec
            .env
            .map_or(Environment::None, |l| Environment::Constant([l; 3]));
        let scene = Scene {
            lights: lights.clone(),
            environment,
        };
        let mut cells = Vec::new();
        let mut notes = BTreeMap::new();
        for variant in &args.variants {
            let transport = parse_variant(variant, args.bounce_rays)?;
            let start = std::time::Instant::now();
            let sol = solve(&graph, &field, &scene, solid.as_ref(), transport)?;
            let ss = vertex_single_scattering(
                &graph.surface,
                &field,
                &scene,
                solid.as_ref(),
                &transport,
                EYE,
                args.ss_samples,
            );
            let seconds = start.elapsed().as_secs_f64();
            let exitance: Vec<[f32; 3]> = sol
                .vertex_j_plus
                .iter()
                .zip(&ss)
                .map(|(x, s)| std::array::from_fn(|c| (f64::from(x[c]) + s[c]) as f32))
                .collect();
            let display = ExitanceMesh {
                mesh: graph.surface.clone(),
                exitance,
                eta: spec.eta,
            };
            let frame = FrameDesc {
                width: width as u32,
                height: (reference.len() / width) as u32,
                camera: Some(Camera {
                    eye: EYE,
                    target: DVec3::ZERO,
                    fovy_deg: FOVY,
                }),
                radiance: RadianceMode::Physical,
                specular: true,
                ..FrameDesc::default()
            };
            let mut renderer = HeadlessRenderer::new(&ctx, &display, &scene, &frame)?;
            let image = renderer.render_frame(&ctx)?.image;
            if let Some(out) = &args.out {
                let name = variant.replace(['/', '='], "_");
                image.write(&out.join(format!("{}-{name}.exr", spec.name)), 0.0)?;
            }
            let (per, all) = relative_rms(&image.pixels, &reference);
            cells.push(format!(
                "{:.1}, {:.1}, {:.1} ({:.1})",
                100.0 * per[0],
                100.0 * per[1],
                100.0 * per[2],
                100.0 * all
            ));
            notes.insert(
                variant.clone(),
                format!("{seconds:.1} s, clamped {:?}", sol.vertex_clamped),
            );
            if spec.env.is_some() && spec.lights.is_empty() {
                // Constant exact exitance: how flat is ours per vertex?
                let cv = coefficient_of_variation(&sol.vertex_exitance);
                notes.insert(
                    format!("{variant} cv"),
                    format!(
                        "{:.2}, {:.2}, {:.2} %",
                        100.0 * cv[0],
                        100.0 * cv[1],
                        100.0 * cv[2]
                    ),
                );
            }
        }
        println!("| {} | {} |", spec.name, cells.join(" | "));
        for (k, v) in notes {
            eprintln!("   {}: {k}: {v}", spec.name);
        }
    }
    Ok(())
}

fn coefficient_of_variation(values: &[[f64; 3]]) -> [f64; 3] {
    let n = values.len().max(1) as f64;
    std::array::from_fn(|c| {
        let mean = values.iter().map(|v| v[c]).sum::<f64>() / n;
        let var = values.iter().map(|v| (v[c] - mean).powi(2)).sum::<f64>() / n;
        var.sqrt() / mean.abs().max(1e-300)
    })
}

fn solve(
    graph: &QuadGraph,
    field: &MaterialField,
    scene: &Scene,
    solid: &dyn Solid,
    transport: Transport,
) -> Result<solver::CpuSolution> {
    let params = CpuSolveParams {
        transport,
        ..CpuSolveParams::default()
    };
    Ok(solver::solve(graph, field, scene, Some(solid), &params)?)
}
