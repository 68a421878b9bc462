//! Our renders against the committed path-traced references (`tests/reference/pt/`, Mitsuba 3.9.1,
//! made by `tools/pt_reference.py`; commands and noise in the README there), with the metric of
//! `tools/compare_exr.py`: relative RMS sqrt(sum (ours - ref)^2 / sum ref^2) over the pixels the
//! object covers fully (reference alpha >= 0.999). CI-sized: the bakes use `--resolution 24`,
//! where the errors measured by the full commands (benches/RESULTS.md, "Diffusion against
//! path-traced references") are the same to 0.2 points.
//!
//! Tolerances: the error measured at `--resolution 24` plus a margin of about one reference-noise
//! level (1.3-1.6%), so a regression of the chain (camera, normalization, Fresnel, the reflection
//! term, the source term) fails while reference noise and driver rounding do not. Each test also
//! checks what it must not pass: without the environment's reflection, or with the boundary-flux
//! source, the same check fails by a wide margin.
//!
//! And an exact check of the environment's mirror reflection: an object with J+ = 0 in a constant
//! (or linear SH) environment shows F_r(eta, theta_o) L(r) in every pixel.

use std::path::Path;

use glam::DVec3;
use translucent::headless::{render_headless, ExitanceMesh, FrameDesc, HeadlessRenderer};
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{self, Camera, RadianceMode};
use translucent::scene::{Environment, Light};
use translucent::solver::gpu::GpuSolveParams;
use translucent::solver::transport::{SingleScattering, Transport};
use translucent::solver::{self, CpuSolveParams, SolverError};
use translucent::vk::LinearImage;
use translucent::{ObjectParams, QuadGraph, TranslucentObject};
use translucent_tests::{render_once, workspace_root, GpuTest};

const EYE: DVec3 = DVec3::new(0.0, 20.0, 60.0);
const FOVY: f64 = 30.0;
const SIZE: u32 = 96;
const RADIUS: f64 = 10.0;

/// A path-traced reference: (rgb, alpha) per pixel, row 0 at the top.
fn reference(name: &str) -> Vec<([f32; 3], f32)> {
    let path = workspace_root().join("tests/reference/pt").join(name);
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
    )
    .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let size = image.layer_data.size;
    assert_eq!(
        (size.width(), size.height()),
        (SIZE as usize, SIZE as usize)
    );
    image.layer_data.channel_data.pixels.1
}

/// Relative RMS over the fully covered pixels: (per channel, all).
fn relative_rms(ours: &LinearImage, reference: &[([f32; 3], f32)]) -> ([f64; 3], f64) {
    let (mut err, mut norm) = ([0.0f64; 3], [0.0f64; 3]);
    let mut pixels = 0;
    for (o, (r, a)) in ours.pixels.iter().zip(reference) {
        assert!(o.iter().all(|v| v.is_finite()), "non-finite pixel {o:?}");
        if *a >= 0.999 {
            pixels += 1;
            for c in 0..3 {
                err[c] += (f64::from(o[c]) - f64::from(r[c])).powi(2);
                norm[c] += f64::from(r[c]).powi(2);
            }
        }
    }
    assert!(pixels > 1000, "{pixels} object pixels");
    let per = std::array::from_fn(|c| (err[c] / norm[c]).sqrt());
    (
        per,
        (err.iter().sum::<f64>() / norm.iter().sum::<f64>()).sqrt(),
    )
}

fn frame(specular: bool) -> FrameDesc {
    FrameDesc {
        width: SIZE,
        height: SIZE,
        camera: Some(camera()),
        radiance: RadianceMode::Physical,
        specular,
        ..FrameDesc::default()
    }
}

/// The 20 mm sphere baked as `translucent render --shape sphere --size-mm 20 --resolution 24`.
fn sphere_graph() -> (QuadGraph, Shape) {
    let ball = Shape::Sphere { radius: RADIUS };
    let params = BakeParams {
        resolution: 24,
        ..BakeParams::default()
    };
    let graph = QuadGraph::bake(&ball.triangulate(96), &ball, &params, &mut |_| {})
        .expect("bake")
        .0;
    (graph, ball)
}

fn camera() -> Camera {
    Camera {
        eye: EYE,
        target: DVec3::ZERO,
        fovy_deg: FOVY,
    }
}

/// The graph's display surface with the given exitance, and the scene of `lights` in
/// `environment` (shaded: the specular term and the environment's reflection).
fn display(
    graph: &QuadGraph,
    exitance: Vec<[f32; 3]>,
    lights: Vec<Light>,
    eta: f64,
    environment: Environment,
) -> (ExitanceMesh, scene::Scene) {
    (
        ExitanceMesh {
            mesh: graph.surface.clone(),
            exitance,
            eta,
        },
        scene::Scene {
            lights,
            environment,
        },
    )
}

/// Unpolarized Fresnel reflectance from outside at `cos_i` (the textbook formula).
fn fresnel_r(eta: f64, cos_i: f64) -> f64 {
    let sin_t = (1.0 - cos_i * cos_i).max(0.0).sqrt() / eta;
    let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    0.5 * (rs * rs + rp * rp)
}

/// The view ray through pixel (x, y)'s centre hitting the exact sphere: (cos_i, reflected dir).
fn sphere_pixel(x: u32, y: u32) -> Option<(f64, DVec3)> {
    let forward = (-EYE).normalize();
    let right = forward.cross(DVec3::Y).normalize();
    let up = right.cross(forward);
    let half = (FOVY.to_radians() / 2.0).tan();
    let px = (2.0 * (f64::from(x) + 0.5) / f64::from(SIZE) - 1.0) * half;
    let py = (1.0 - 2.0 * (f64::from(y) + 0.5) / f64::from(SIZE)) * half;
    let d = (forward + px * right + py * up).normalize();
    let b = d.dot(EYE);
    let disc = b * b - (EYE.length_squared() - RADIUS * RADIUS);
    (disc > 0.0).then(|| {
        let n = (EYE + d * (-b - disc.sqrt())) / RADIUS;
        let cos_i = -d.dot(n);
        (cos_i, d - 2.0 * d.dot(n) * n)
    })
}

#[test]
fn environment_reflection_is_fresnel_times_the_reflected_radiance() {
    let gpu = GpuTest::new();
    let (graph, _) = sphere_graph();
    let vertices = graph.surface.positions.len();
    let eta = 1.3;
    // Constant L, and a linear SH sky L(d) = a + b d_y (exact in orders 0 and 1).
    let (a, b) = (0.6, 0.4);
    let mut sh = [[0.0; 3]; 9];
    sh[0] = [a / 0.282095, 2.0 * a / 0.282095, 0.0];
    sh[1] = [b / 0.488603, 0.0, 0.0];
    let constant = [0.5, 1.0, 2.0];
    for (environment, expected) in [
        (
            Environment::Constant(constant),
            Box::new(move |_: DVec3| constant) as Box<dyn Fn(DVec3) -> [f64; 3]>,
        ),
        (
            Environment::SphericalHarmonics(sh),
            Box::new(move |r: DVec3| [a + b * r.y, 2.0 * a, 0.0]),
        ),
    ] {
        // J+ = 0: only the reflection is left.
        let (mesh, scene) = display(&graph, vec![[0.0; 3]; vertices], vec![], eta, environment);
        let mut renderer = HeadlessRenderer::new(&gpu.ctx, &mesh, &scene, &frame(true)).unwrap();
        let image = renderer.render_frame(&gpu.ctx).unwrap().image;
        let (mut worst, mut checked) = (0.0f64, 0);
        for y in 0..SIZE {
            for x in 0..SIZE {
                let got = image.pixels[(y * SIZE + x) as usize];
                assert!(got.iter().all(|v| v.is_finite()), "{got:?}");
                // Away from the silhouette, where the tessellated sphere's interpolated normal is
                // the exact one to ~1e-3.
                let Some((cos_i, r)) = sphere_pixel(x, y).filter(|p| p.0 > 0.4) else {
                    continue;
                };
                let want = expected(r).map(|l| fresnel_r(eta, cos_i) * l);
                for c in 0..3 {
                    let err = (f64::from(got[c]) - want[c]).abs() / want[0].max(want[1]);
                    worst = worst.max(err);
                }
                checked += 1;
            }
        }
        assert!(checked > 1500, "{checked} pixels");
        // 2%: the 96-segment sphere's facets and f32 shading, far below F_r's variation
        // (0.017 at normal incidence to 0.06 at cos 0.4).
        assert!(
            worst < 0.02,
            "{environment:?}: worst relative error {worst}"
        );

        // Without specular nothing is reflected.
        let mut dark = HeadlessRenderer::new(&gpu.ctx, &mesh, &scene, &frame(false)).unwrap();
        let image = dark.render_frame(&gpu.ctx).unwrap().image;
        assert!(image.pixels.iter().all(|p| p[..3] == [0.0; 3]));
    }
    // A non-finite environment is a typed error, not a NaN image.
    let (mesh, scene) = display(
        &graph,
        vec![[0.0; 3]; vertices],
        vec![],
        eta,
        Environment::None,
    );
    let mut renderer = HeadlessRenderer::new(&gpu.ctx, &mesh, &scene, &frame(true)).unwrap();
    let bad = scene::Scene {
        environment: Environment::Constant([f64::NAN, 0.0, 0.0]),
        ..scene.clone()
    };
    assert!(renderer.object().set_lights(&bad).is_err());
    assert!(HeadlessRenderer::new(&gpu.ctx, &mesh, &bad, &frame(true)).is_err());
    drop(renderer);
    gpu.finish();
}

/// The whole GPU frame (gather, multi-level mixed-precision Jacobi, J+, shading with the
/// environment's reflection) at the real-time defaults against `marble-sphere-env-eta1.3.exr`.
#[test]
fn gpu_frame_matches_the_path_traced_marble_sphere_in_an_environment() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, ball) = sphere_graph();
    let field = MaterialField::Homogeneous(
        Material::new(
            Material::preset("marble").unwrap().sigma_s,
            Material::preset("marble").unwrap().sigma_a,
            1.3,
        )
        .unwrap(),
    );
    let scene = scene::Scene {
        lights: vec![],
        environment: Environment::Constant([1.0; 3]),
    };
    let params = GpuSolveParams::default();
    let reference = reference("marble-sphere-env-eta1.3.exr");
    let mut errors = Vec::new();
    for reflect in [true, false] {
        // Without the reflection: no specular (there is no light, so the environment's mirror
        // reflection is all the specular term draws).
        let mut object = TranslucentObject::new(
            ctx,
            std::sync::Arc::new(graph.clone()),
            &field,
            &scene,
            &ObjectParams {
                solve: params.clone(),
                specular: reflect,
                single_level_nodes: 0,
                // why: the errors measured here are the solve's, without the march (the library's
                // default since wave 6).
                single_scattering: None,
                // why: the bounds were measured with the material's own (classical) D.
                diffusion: field.diffusion(),
                ..ObjectParams::default()
            },
        )
        .unwrap();
        object.set_camera(Some(camera())).unwrap();
        let image = render_once(ctx, &mut object, SIZE, SIZE).0.image;
        let report = object
            .quadgraph()
            .expect("quadgraph")
            .report(ctx, &field, &scene, Some(&ball))
            .unwrap();
        assert!(report.iterations.iter().all(|&n| n > 0), "{report:?}");
        errors.push(relative_rms(&image, &reference));
    }
    // Measured 1.6, 0.9, 1.5 (1.4)% at --resolution 24 and 48; reference noise 1.3%.
    let (per, all) = errors[0];
    assert!(per.iter().all(|&e| e < 0.03) && all < 0.025, "{errors:?}");
    // Without the reflection the reference's 4.5% of mirrored sky is missing: 7.5%.
    assert!(errors[1].1 > 0.06, "{errors:?}");
    gpu.finish();
}

/// Energy balance of the collimated source (DESIGN 2.7) on a sphere: its particular solution is
/// the flat half-space's, so sum q dA = exitance + absorption holds to the curvature's error
/// (measured 0.1-0.9% on the milk sphere at resolution 24), not to round-off.
const COLLIMATED_BALANCE: f64 = 0.02;

/// The collimated source's error on the milk sphere (measured 8.6%; 10.1% since the depth-sampled
/// surface's profile has the curvature term of wave 7, exact on the sphere's closed form) and
/// its gain over the boundary flux (measured 3.3, now 1.8 points): bounds with ~1 point of room
/// for the bake's noise.
const COLLIMATED_MILK: f64 = 0.11;
const COLLIMATED_GAIN: f64 = 0.01;

/// The opt-in beam source against `skimmilk-sphere-dir-eta1.exr` (the scene where the boundary
/// flux is worst): the CPU f64 solution, shaded by the same pass.
#[test]
fn collimated_source_lowers_the_error_of_the_directionally_lit_milk_sphere() {
    let gpu = GpuTest::new();
    let (graph, ball) = sphere_graph();
    let milk = Material::preset("skimmilk").unwrap();
    let field = MaterialField::Homogeneous(Material::new(milk.sigma_s, milk.sigma_a, 1.0).unwrap());
    let light: Light = "dir:0.5,-1,-0.5:4,4,4".parse().unwrap();
    let scene = scene::Scene {
        lights: vec![light],
        environment: Environment::None,
    };
    let reference = reference("skimmilk-sphere-dir-eta1.exr");
    let mut errors = Vec::new();
    for beam_source in [true, false] {
        let params = CpuSolveParams {
            transport: if beam_source {
                // Single scattering is view-dependent (added per pixel), left out here.
                Transport {
                    single_scattering: SingleScattering::Off,
                    ..Transport::collimated()
                }
            } else {
                Transport::default()
            },
            ..CpuSolveParams::default()
        };
        let sol = solver::solve(&graph, &field, &scene, Some(&ball), &params).unwrap();
        let e = sol.energy;
        // fv conserves energy exactly with the boundary flux; the collimated source's particular
        // solution is the flat half-space's analytic one, not the discrete one.
        let bound = if beam_source {
            COLLIMATED_BALANCE
        } else {
            1e-6
        };
        for c in 0..3 {
            let balance = e.transmitted_input[c] - e.exitance[c] - e.absorbed[c];
            assert!(balance.abs() < bound * e.transmitted_input[c], "{e:?}");
        }
        let (mesh, display) = display(
            &graph,
            sol.vertex_j_plus.clone(),
            vec![light],
            1.0,
            Environment::None,
        );
        let image = render_headless(&gpu.ctx, &mesh, &display, &frame(false))
            .unwrap()
            .image;
        errors.push(relative_rms(&image, &reference));
    }
    println!("collimated, flux: {errors:?}");
    // Measured (the collimated source of DESIGN 2.7, CI bake): 11.8, 7.8, 5.5 (8.6)%; boundary
    // flux 15.9, 10.7, 8.6 (11.9)%; noise 1.6%. (The earlier volume deposit along the beam gave
    // 5.8% here but needed cells under a mean free path; this needs none.)
    assert!(errors[0].1 < COLLIMATED_MILK, "{errors:?}");
    assert!(errors[1].1 > errors[0].1 + COLLIMATED_GAIN, "{errors:?}");

    // One bounce casts rays between surface points: without the solid it is a typed error.
    let params = CpuSolveParams {
        transport: Transport {
            bounce_rays: 8,
            ..Transport::collimated()
        },
        ..CpuSolveParams::default()
    };
    assert!(matches!(
        solver::solve(&graph, &field, &scene, None, &params),
        Err(SolverError::BadParameter { .. })
    ));
    gpu.finish();
}

#[test]
fn committed_references_have_their_commands() {
    let dir = workspace_root().join("tests/reference/pt");
    let readme = std::fs::read_to_string(dir.join("README.md")).unwrap();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let name = entry.unwrap().file_name().to_string_lossy().into_owned();
        if Path::new(&name).extension().is_some_and(|e| e == "exr") {
            assert!(
                readme.contains(&format!("--out tests/reference/pt/{name}")),
                "{name}: no command in tests/reference/pt/README.md"
            );
        }
    }
}

/// Relative RMS of an absorbing sphere at the CI bake (`--resolution 24`, GPU frame, boundary
/// flux, no single scattering: front-lit, render's rule skips it there), measured: skin1 Shepard
/// 20.8%, interior 16.0%; ketchup Shepard 42.4%, interior 36.5% (the default bake, benches/
/// RESULTS.md "All references, term by term": 20.0, 16.6, 42.9, 39.3). The model's error, not
/// an accuracy target (issue 12 wants far less): bounds about one reference-noise level
/// (1.1-1.6%) above, so a regression of the chain for absorbing channels (the presets, the
/// clamping of negative J+, the interior profile) fails while noise does not. Wave 7: the
/// interior profile's curvature term (exact against the sphere's closed form: constant-
/// environment albedo within 0.4%) brightens the convex lit side: interior 16.0 -> 20.3% (skin1)
/// and 36.5 -> 45.2% (ketchup) against these front-lit eta-1 references (the diffusion model's
/// own excess for absorbing channels, which the planar profile's darkening used to hide).
const SKIN1_SHEPARD: f64 = 0.225;
const SKIN1_INTERIOR: f64 = 0.215;
const KETCHUP_SHEPARD: f64 = 0.44;
const KETCHUP_INTERIOR: f64 = 0.465;
/// Skin1's image against ketchup's reference: far above any bound (measured below).
const WRONG_MATERIAL: f64 = 0.5;

/// Relative RMS over the pixels `mask`'s alpha covers fully (the ketchup reference's own alpha is
/// below 0.999 everywhere: camera rays cross it unscattered; the skin1 file is the same sphere).
fn relative_rms_masked(
    ours: &LinearImage,
    reference: &[([f32; 3], f32)],
    mask: &[([f32; 3], f32)],
) -> ([f64; 3], f64) {
    let masked: Vec<_> = reference
        .iter()
        .zip(mask)
        .map(|((rgb, _), (_, a))| (*rgb, *a))
        .collect();
    relative_rms(ours, &masked)
}

/// The GPU frame on the skin1 and ketchup spheres (issue 12 item 6), both surface queries,
/// against `skin1-sphere-dir-eta1.exr` and `ketchup-sphere-dir-eta1.exr`.
#[test]
fn gpu_frame_against_the_path_traced_skin1_and_ketchup_spheres() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, _) = sphere_graph();
    let graph = std::sync::Arc::new(graph);
    let scene = scene::Scene {
        lights: vec!["dir:0.5,-1,-0.5:4,4,4".parse().unwrap()],
        environment: Environment::None,
    };
    let mask = reference("skin1-sphere-dir-eta1.exr");
    let mut errors = Vec::new();
    let mut skin1_image = None;
    for (name, bounds) in [
        ("skin1", [SKIN1_SHEPARD, SKIN1_INTERIOR]),
        ("ketchup", [KETCHUP_SHEPARD, KETCHUP_INTERIOR]),
    ] {
        let preset = Material::preset(name).unwrap();
        let field =
            MaterialField::Homogeneous(Material::new(preset.sigma_s, preset.sigma_a, 1.0).unwrap());
        let reference = reference(&format!("{name}-sphere-dir-eta1.exr"));
        for (surface, bound) in [
            (solver::transport::SurfaceReconstruction::Shepard, bounds[0]),
            (
                solver::transport::SurfaceReconstruction::Interior,
                bounds[1],
            ),
        ] {
            let mut object = TranslucentObject::new(
                ctx,
                graph.clone(),
                &field,
                &scene,
                &ObjectParams {
                    solve: GpuSolveParams {
                        surface,
                        ..GpuSolveParams::default()
                    },
                    specular: false,
                    single_level_nodes: 0,
                    // why: the solve's error alone, without the march (on by default).
                    single_scattering: None,
                    // why: the bounds were measured with the material's own (classical) D.
                    diffusion: field.diffusion(),
                    ..ObjectParams::default()
                },
            )
            .unwrap();
            object.set_camera(Some(camera())).unwrap();
            let image = render_once(ctx, &mut object, SIZE, SIZE).0.image;
            let error = relative_rms_masked(&image, &reference, &mask);
            if skin1_image.is_none() {
                skin1_image = Some(image.clone());
            }
            println!("{name} {surface:?}: {error:?}");
            errors.push((name, surface, error, bound));
        }
    }
    for (name, surface, (per, all), bound) in &errors {
        assert!(
            all < bound,
            "{name} {surface:?}: {per:?} ({all}) >= {bound}"
        );
    }
    // What it must not pass: skin1's image against ketchup's reference (green and blue differ
    // by a factor of 10-60) is far outside the bounds.
    assert!(
        relative_rms_masked(
            &skin1_image.unwrap(),
            &reference("ketchup-sphere-dir-eta1.exr"),
            &mask
        )
        .1 > WRONG_MATERIAL,
        "the metric does not see the material"
    );
    gpu.finish();
}

/// Relative RMS of the two absorbing spheres at the CI bake with `render`'s default model for a
/// homogeneous material (the second-collision source, the moments query, single scattering
/// added whole; Shepard surface), each diffusion coefficient (`material::DiffusionCoefficient`,
/// `render --diffusion-coefficient`). Measured (this test's output, lavapipe): skin1 classical
/// 12.6%, Grosjean 12.2%; ketchup classical 23.7%, Grosjean 23.4% (96 px at the default bake,
/// benches/RESULTS.md "Diffusion coefficient at low albedo": 12.1, 11.9, 24.2, 24.1). Half the
/// boundary-flux bounds above: the default model's absorbing channels (ketchup's green and
/// blue 2-6% instead of clamped rings or zero) must not regress to the old ones. Bounds about
/// one reference-noise level above the measured error.
const DEFAULT_MODEL_SKIN1: f64 = 0.14;
const DEFAULT_MODEL_KETCHUP: f64 = 0.255;

/// The default model of `render` (second-collision source, single scattering whole) on the skin1
/// and ketchup spheres with either diffusion coefficient, against the path-traced references.
#[test]
fn default_model_against_the_path_traced_skin1_and_ketchup_spheres_with_either_d() {
    use translucent::frame::{ScatterMode, ScatterParams};
    use translucent::material::DiffusionCoefficient;
    use translucent::solver::transport::ExitQuery;
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (graph, _) = sphere_graph();
    let graph = std::sync::Arc::new(graph);
    let scene = scene::Scene {
        lights: vec!["dir:0.5,-1,-0.5:4,4,4".parse().unwrap()],
        environment: Environment::None,
    };
    let mask = reference("skin1-sphere-dir-eta1.exr");
    let mut errors = Vec::new();
    for (name, bound) in [
        ("skin1", DEFAULT_MODEL_SKIN1),
        ("ketchup", DEFAULT_MODEL_KETCHUP),
    ] {
        let preset = Material::preset(name).unwrap();
        let reference = reference(&format!("{name}-sphere-dir-eta1.exr"));
        for kind in [
            DiffusionCoefficient::Classical,
            DiffusionCoefficient::Grosjean,
        ] {
            let field = MaterialField::Homogeneous(
                Material::new(preset.sigma_s, preset.sigma_a, 1.0)
                    .unwrap()
                    .with_diffusion(kind),
            );
            let mut object = TranslucentObject::new(
                ctx,
                graph.clone(),
                &field,
                &scene,
                &ObjectParams {
                    solve: GpuSolveParams {
                        exit: ExitQuery::Moments,
                        collimated: true,
                        second_collision: true,
                        ..GpuSolveParams::default()
                    },
                    specular: false,
                    single_level_nodes: 0,
                    single_scattering: Some(ScatterParams {
                        mode: ScatterMode::Full,
                        skip_front_lit: false,
                        ..ScatterParams::default()
                    }),
                    diffusion: kind,
                    ..ObjectParams::default()
                },
            )
            .unwrap();
            object.set_camera(Some(camera())).unwrap();
            let image = render_once(ctx, &mut object, SIZE, SIZE).0.image;
            let error = relative_rms_masked(&image, &reference, &mask);
            println!("{name} {kind:?}: {error:?}");
            errors.push((name, kind, error, bound));
        }
    }
    for (name, kind, (per, all), bound) in &errors {
        assert!(all < bound, "{name} {kind:?}: {per:?} ({all}) >= {bound}");
    }
    gpu.finish();
}
