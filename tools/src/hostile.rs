//! Hostile-input entry points (issue 17), shared by the fuzz targets (`fuzz/fuzz_targets/`, nightly
//! cargo-fuzz) and the regression tests (`tools/tests/fuzz_corpus.rs`, stable, in CI). Each takes
//! arbitrary bytes, drives one reader or parser as the command line does, and returns what the
//! input was refused for as `Err(message)`. It panics only when an invariant breaks: a panic in the
//! code under test, or an accepted value that is not what the parser promises (a light whose
//! direction does not normalize, a camera whose view matrix is not finite, a graph that does not
//! survive its own cache round trip, a solve that is not finite).
//!
//! ```
//! use translucent_tools::hostile;
//! assert!(hostile::run("scene_strings", b"\x00dir:0,-1,0:1,1,1").is_ok());
//! assert!(hostile::run("scene_strings", b"\x00dir:0,0,0:1,1,1").is_err());
//! assert!(hostile::run("vol", b"VOL\x03").is_err());
//! ```

use std::path::Path;

use clap::Parser as _;
use glam::DVec3;
use translucent::limits::Limits;
use translucent::material::{MaterialField, VolGrid};
use translucent::mesh::{MeshError, MeshSolid, TriMesh, ValidateOptions};
use translucent::quadgraph::{cache, BakeParams};
use translucent::scene::{Camera, Environment, Light, Scene};
use translucent::solver::{self, CpuSolveParams};
use translucent::QuadGraph;

use crate::material_args::MaterialArgs;
use crate::object_args::shape_by_name;
use crate::scene_args::{parse_camera, parse_light};
use crate::{Cli, Command};

/// The targets, by the name of their fuzz target and corpus directory.
pub const TARGETS: [&str; 6] = ["obj", "vol", "cache", "env", "scene_strings", "render_argv"];

/// Runs the entry point `target` (one of [`TARGETS`]) on `data`.
pub fn run(target: &str, data: &[u8]) -> Result<(), String> {
    match target {
        "obj" => obj(data),
        "vol" => vol(data),
        "cache" => cache_bytes(data),
        "env" => env_exr(data),
        "scene_strings" => scene_strings(data),
        "render_argv" => render_argv(data),
        other => panic!("no hostile-input target {other:?} (known: {TARGETS:?})"),
    }
}

/// The limits the entry points run under: the defaults, lowered so that no input can make a
/// fuzzing process allocate more than a few hundred MB (libFuzzer's `-rss_limit_mb=2048` would
/// report it as a crash) or take more than a fraction of a second.
pub fn limits() -> Limits {
    Limits {
        max_vertices: 100_000,
        max_triangles: 100_000,
        max_file_bytes: 16 << 20,
        max_vol_voxels: 1 << 20,
        max_vol_axis: 1024,
        max_lattice_nodes: 1 << 18,
        max_surface_samples: 1 << 20,
        max_env_texels: 1 << 20,
    }
}

/// The bake the `obj` target runs: one level, 4 cells across (tiny, so each input is milliseconds).
pub fn tiny_bake() -> BakeParams {
    BakeParams {
        resolution: 4,
        levels: 1,
        limits: limits(),
        ..BakeParams::default()
    }
}

fn text<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// OBJ text -> load -> validate (the first byte's low bit: default or forced) -> normalize ->
/// solid -> bake at a tiny resolution -> cache round trip -> a short CPU solve.
pub fn obj(data: &[u8]) -> Result<(), String> {
    let (force, text_bytes) = match data.split_first() {
        Some((flags, rest)) => (flags & 1 == 1, rest),
        None => (false, data),
    };
    let mut mesh = match TriMesh::parse_obj(text_bytes, Path::new("fuzz.obj"), &limits()) {
        Ok(mesh) => mesh,
        // Every parse error must carry its line: tobj refusing what the line checks accepted is a
        // gap in them.
        Err(e @ MeshError::Obj { .. }) => panic!("tobj refused what the line checks passed: {e}"),
        Err(e) => {
            let message = e.to_string();
            if matches!(e.root(), MeshError::Syntax { .. }) {
                assert!(
                    message.starts_with("fuzz.obj:") && e.line().is_some(),
                    "a syntax error without FILE:LINE: {message}"
                );
            }
            return Err(message);
        }
    };
    let vertices = mesh.positions.len();
    assert!(
        mesh.indices
            .iter()
            .flatten()
            .all(|&i| (i as usize) < vertices)
            && mesh.positions.iter().all(|p| p.is_finite()),
        "a loaded mesh with an index out of range or a non-finite position"
    );
    let options = if force {
        ValidateOptions::forced()
    } else {
        ValidateOptions::default()
    };
    mesh.validate(&options).map_err(text)?;
    let (mut mesh, _) = mesh.normalized(50.0).map_err(text)?;
    if mesh.normals.len() != mesh.positions.len() {
        mesh.compute_normals();
    }
    let solid = MeshSolid::new(mesh).map_err(text)?;
    let surface = solid.mesh().clone();
    let params = tiny_bake();
    let (graph, _stats) = QuadGraph::bake(&surface, &solid, &params, &mut |_| {}).map_err(text)?;
    check_graph(&graph);
    let key = cache::cache_key(&surface, &params);
    let back = QuadGraph::from_cache_bytes(&graph.to_cache_bytes(key), Path::new("rt"), Some(key))
        .unwrap_or_else(|e| panic!("a fresh bake does not survive its cache round trip: {e}"));
    assert_eq!(back.levels.len(), graph.levels.len());
    solve_is_finite(&graph, true)
}

/// The cache target's seeds, in the current [`cache::FORMAT_VERSION`]: a tetrahedron baked at
/// [`tiny_bake`] with one and with two levels, as a whole file (first byte 0: read as given) and as
/// a bare payload (first byte 1: [`cache_bytes`] wraps it in a valid header and checksum, so the
/// fuzzer's mutations reach the decoder). A format change makes the committed seeds stale (the
/// reader refuses them at the version or the decoder): `fuzz_corpus` tests that they are accepted,
/// and `cargo run --release -p translucent-tools --example fuzz_replay -- make-cache-seeds DIR`
/// writes them again.
pub fn cache_seeds() -> Result<Vec<(&'static str, Vec<u8>)>, String> {
    const TETRA: &[u8] =
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    let mut mesh = TriMesh::parse_obj(TETRA, Path::new("tetra.obj"), &limits()).map_err(text)?;
    mesh.validate(&ValidateOptions::default()).map_err(text)?;
    let (mut mesh, _) = mesh.normalized(50.0).map_err(text)?;
    mesh.compute_normals();
    let solid = MeshSolid::new(mesh).map_err(text)?;
    let surface = solid.mesh().clone();
    let mut seeds = Vec::new();
    for (levels, file, payload) in [
        (
            1,
            Some("seed-tetra-1level-file"),
            "seed-tetra-1level-payload",
        ),
        (2, None, "seed-tetra-2levels-payload"),
    ] {
        let params = BakeParams {
            levels,
            resolution: 4 << (levels - 1),
            ..tiny_bake()
        };
        let (graph, _) = QuadGraph::bake(&surface, &solid, &params, &mut |_| {}).map_err(text)?;
        let key = cache::cache_key(&surface, &params);
        let bytes = graph.to_cache_bytes(key);
        if let Some(name) = file {
            seeds.push((name, [&[0u8][..], &bytes].concat()));
        }
        // The payload sits between the 32-byte header and the 8-byte checksum.
        let body = &bytes[32..bytes.len() - 8];
        seeds.push((payload, [&[1u8][..], body].concat()));
    }
    Ok(seeds)
}

/// Properties every baked or loaded graph must have for its consumers.
fn check_graph(graph: &QuadGraph) {
    let stats = graph.stats();
    assert_eq!(stats.levels.len(), graph.levels.len());
    let (centre, radius) = graph.finest().bounding_sphere();
    assert!(centre.is_finite() && radius.is_finite() && radius > 0.0);
}

/// A short CPU solve (8 Jacobi sweeps, no exact solve) under a directional light and an
/// environment: J+ must come out finite (DESIGN: no NaN/Inf ever leaves a pass). A fresh bake must
/// be solvable; a loaded graph may be refused with a typed error (`Err`).
fn solve_is_finite(graph: &QuadGraph, baked: bool) -> Result<(), String> {
    let Ok(material) = translucent::material::Material::preset("marble") else {
        panic!("the marble preset is valid");
    };
    let scene = Scene {
        lights: vec![Light::Directional {
            direction: DVec3::new(0.3, -1.0, 0.2).normalize(),
            irradiance: [3.0; 3],
        }],
        environment: Environment::Constant([0.2; 3]),
    };
    let params = CpuSolveParams {
        iterations: vec![8],
        exact: false,
        ..CpuSolveParams::default()
    };
    match solver::solve(
        graph,
        &MaterialField::Homogeneous(material),
        &scene,
        None,
        &params,
    ) {
        Ok(solution) => {
            assert!(
                solution
                    .vertex_j_plus
                    .iter()
                    .flatten()
                    .all(|v| v.is_finite()),
                "the CPU solve of an accepted graph is not finite"
            );
            Ok(())
        }
        Err(e) if baked => panic!("the CPU solve refused a fresh bake: {e}"),
        Err(e) => Err(e.to_string()),
    }
}

/// `.vol` bytes -> reader -> material field -> samples inside and around the box -> the grid's own
/// bytes read back equal.
pub fn vol(data: &[u8]) -> Result<(), String> {
    let grid = VolGrid::from_bytes_with_limits(data, &limits()).map_err(text)?;
    let back = VolGrid::from_bytes_with_limits(&grid.to_bytes(), &limits())
        .unwrap_or_else(|e| panic!("an accepted grid does not read back: {e}"));
    assert!(back == grid, "an accepted grid reads back different");
    let (lo, hi) = (grid.bbox_min, grid.bbox_max);
    let field = MaterialField::grid(grid, 1.3).map_err(text)?;
    for i in 0..64 {
        // A 4 x 4 x 4 pattern from 25% outside the box on one side to 25% on the other.
        let t = DVec3::new((i % 4) as f64, ((i / 4) % 4) as f64, (i / 16) as f64) / 2.0 - 0.25;
        let p = lo + (hi - lo) * t;
        let c = field.sample(p);
        for channel in 0..3 {
            let (s, a) = (c.sigma_s[channel], c.sigma_a[channel]);
            assert!(
                s.is_finite() && a.is_finite() && s >= 0.0 && a >= 0.0 && s + a > 0.0,
                "sample at {p}: sigma_s' {s}, sigma_a {a}"
            );
        }
    }
    Ok(())
}

/// A cache file of a graph whose payload is `payload`: the header and checksum made valid, so that
/// the fuzzer reaches the decoder and the content checks behind them.
pub fn cache_file(payload: &[u8], key: u64) -> Vec<u8> {
    let mut bytes = Vec::with_capacity(payload.len() + 40);
    bytes.extend_from_slice(b"TQGRAPH\0");
    bytes.extend_from_slice(&cache::FORMAT_VERSION.to_le_bytes());
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.extend_from_slice(&key.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(payload);
    bytes.extend_from_slice(&cache::fnv1a64(payload, cache::FNV_OFFSET).to_le_bytes());
    bytes
}

/// The cache key of the graph `translucent bake --shape sphere --resolution 4 --levels 1`
/// computes: the command-line regression test writes corpus payloads under it, so the command
/// line's own load reaches the decoder.
pub fn cli_sphere_key() -> u64 {
    let Ok(shape) = shape_by_name("sphere", 50.0) else {
        panic!("sphere is a shape");
    };
    let params = BakeParams {
        resolution: 4,
        levels: 1,
        ..BakeParams::default()
    };
    cache::cache_key(&shape.triangulate(96), &params)
}

/// Cache bytes -> cache reader -> stats, bounds, the graph's own bytes read back, a short solve.
/// First byte even: the rest is a whole file (header and checksum as given); odd: the rest is a
/// payload, wrapped in a valid header and checksum.
pub fn cache_bytes(data: &[u8]) -> Result<(), String> {
    const KEY: u64 = 0x5eed;
    let path = Path::new("fuzz.qgraph");
    let graph = match data.split_first() {
        Some((mode, rest)) if mode & 1 == 1 => {
            QuadGraph::from_cache_bytes(&cache_file(rest, KEY), path, Some(KEY))
        }
        Some((_, rest)) => QuadGraph::from_cache_bytes(rest, path, None),
        None => QuadGraph::from_cache_bytes(data, path, None),
    }
    .map_err(text)?;
    check_graph(&graph);
    let back = QuadGraph::from_cache_bytes(&graph.to_cache_bytes(KEY), path, Some(KEY))
        .unwrap_or_else(|e| panic!("an accepted graph does not read back: {e}"));
    assert_eq!(back.levels.len(), graph.levels.len());
    solve_is_finite(&graph, false)
}

/// EXR bytes (an `--env` map) -> the EXR reader -> spherical-harmonic projection -> irradiance
/// on a few normals, which must be finite and non-negative in every channel's sum.
pub fn env_exr(data: &[u8]) -> Result<(), String> {
    let env = Environment::from_exr_bytes(data, Path::new("fuzz.exr"), &limits()).map_err(text)?;
    env.validate()
        .unwrap_or_else(|e| panic!("an accepted map projects to an invalid environment: {e}"));
    for n in [
        DVec3::X,
        DVec3::Y,
        -DVec3::Z,
        DVec3::new(1.0, 2.0, 3.0).normalize(),
    ] {
        let e = env.irradiance(n);
        assert!(
            e.iter().all(|v| v.is_finite()),
            "an accepted map gives irradiance {e:?} on {n}"
        );
    }
    Ok(())
}

/// `--light`, `--camera`, `--sigma-a/--sigma-s` strings -> their parsers. The first byte picks
/// the parser, the rest (UTF-8, lossy) is the option's value; for the coefficients, `|` separates
/// sigma_a from sigma_s and an optional third part is `--eta`.
pub fn scene_strings(data: &[u8]) -> Result<(), String> {
    let Some((&which, rest)) = data.split_first() else {
        return Err("empty".into());
    };
    let value = String::from_utf8_lossy(rest);
    match which % 3 {
        0 => {
            let light = parse_light(&value).map_err(|e| format!("{e:#}"))?;
            light
                .validate()
                .unwrap_or_else(|e| panic!("{value:?} parsed to an invalid light: {e}"));
            for p in [DVec3::ZERO, DVec3::splat(25.0), DVec3::new(-1e3, 7.0, 0.5)] {
                let (irradiance, towards, distance) = light.arriving(p);
                // A point exactly at a point or spot light has no direction to it (the solver
                // clamps the distance to 1e-9 mm there); everywhere else it is a unit vector.
                let on_the_light = distance <= 1e-9;
                assert!(
                    irradiance.iter().all(|v| v.is_finite() && *v >= 0.0)
                        && towards.is_finite()
                        && (on_the_light || (towards.length() - 1.0).abs() < 1e-9)
                        && distance > 0.0,
                    "{value:?}: {light:?} arrives at {p} as {irradiance:?} from {towards}"
                );
            }
        }
        1 => {
            let camera: Camera = parse_camera(&value).map_err(|e| format!("{e:#}"))?;
            // A scene around the target, a quarter of the camera's distance in radius: what
            // `validate` promises is a finite view and projection for such a scene. (A scene far
            // smaller than its distance has near = far in f32: `view_proj`'s own limit.)
            let radius = 0.25 * camera.eye.distance(camera.target);
            let m = camera.view_proj(1.0, camera.target, radius);
            assert!(
                m.is_finite(),
                "{value:?} parsed to {camera:?} whose view matrix is not finite"
            );
        }
        _ => {
            let mut parts = value.splitn(3, '|');
            let args = MaterialArgs {
                material: None,
                sigma_a: parts.next().map(str::to_owned),
                sigma_s: parts.next().map(str::to_owned),
                eta: parts
                    .next()
                    .map(|e| e.trim().parse::<f64>().unwrap_or(f64::NAN)),
                volume: None,
            };
            let field = args.field(50.0, "skimmilk").map_err(|e| format!("{e:#}"))?;
            let c = field.sample(DVec3::ZERO);
            for channel in 0..3 {
                let t = c.sigma_s[channel] + c.sigma_a[channel];
                assert!(
                    t.is_finite() && t > 0.0 && (1.0 / (3.0 * t)).is_finite(),
                    "{value:?}: sigma_t' {t} gives no finite diffusion coefficient"
                );
            }
        }
    }
    Ok(())
}

/// A scene description -> `translucent render` argument parsing: the bytes are the arguments after
/// `translucent render`, separated by NUL or newline; then every option the command checks before
/// any file is read or GPU work starts (frame, lights, material, object, bake parameters). Files
/// named by the arguments (`--mesh`, `--volume`, `--env`) are not opened.
pub fn render_argv(data: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(data);
    let argv: Vec<&str> = std::iter::once("translucent")
        .chain(std::iter::once("render"))
        .chain(text.split(['\0', '\n']))
        .collect();
    let cli = Cli::try_parse_from(&argv).map_err(|e| e.render().to_string())?;
    let Command::Render(args) = cli.command else {
        panic!("`translucent render ...` parsed as another command");
    };
    let frame = args.scene.frame_desc().map_err(|e| format!("{e:#}"))?;
    assert!(frame.width >= 1 && frame.height >= 1);
    args.scene.lights().map_err(|e| format!("{e:#}"))?;
    if args.material.volume.is_none() {
        args.material
            .field(args.object.size_mm, "skimmilk")
            .map_err(|e| format!("{e:#}"))?;
    }
    if args.object.mesh.is_none() {
        let object = args
            .object
            .load(Some("torus"))
            .map_err(|e| format!("{e:#}"))?;
        assert!(!object.surface.indices.is_empty());
    }
    // The bake parameters are checked by the bake itself before it allocates: a bake of nothing
    // runs exactly those checks.
    let params = BakeParams {
        limits: limits(),
        ..args.object.bake_params(&crate::object_args::Resolution {
            cells: match args.object.resolution {
                crate::object_args::ResolutionArg::Cells(n) => n,
                crate::object_args::ResolutionArg::Auto => BakeParams::default().resolution,
            },
            spacing_mm: 0.0,
            auto: None,
        })
    };
    match QuadGraph::bake(&TriMesh::default(), &NoSolid, &params, &mut |_| {}) {
        Err(translucent::quadgraph::BakeError::Parameter { .. }) => {
            Err("bad bake parameter".into())
        }
        Err(_) => Ok(()),
        Ok(_) => panic!("a bake of an empty solid succeeded"),
    }
}

/// A solid with nothing in it, to run the bake's parameter checks alone.
struct NoSolid;

impl translucent::mesh::Solid for NoSolid {
    fn contains(&self, _: DVec3) -> bool {
        false
    }
    fn ray_hit(&self, _: DVec3, _: DVec3, _: f64) -> Option<(f64, DVec3)> {
        None
    }
    fn bounds(&self) -> (DVec3, DVec3) {
        (DVec3::ZERO, DVec3::ZERO)
    }
}
