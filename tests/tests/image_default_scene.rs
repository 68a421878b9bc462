//! Image tests of the headless shading path, with synchronization validation on.
//!
//! - The default scene (sphere, default light, auto camera) at 128x128 against
//!   `tests/reference/default_sphere_128.png` (see `tests/reference/README.md`).
//! - An exact check of the shading formula: a uniform J+ with specular off gives, at the pixel
//!   whose normal faces the camera, L_o = F_t(eta, 0) J+ / (pi eta^2) (physical) and F_t J+ / pi
//!   (paper, DESIGN section 2), to fp16 precision.

use translucent::headless::{render_headless, FrameDesc, HeadlessRenderer};
use translucent::scene::{Light, RadianceMode};
use translucent_tests::{
    compare_to_reference, exitance_scene, workspace_root, GpuTest, ImageTolerance,
};

/// The reference was rendered on lavapipe; other drivers rasterize and round slightly
/// differently, mostly along the silhouette. Mean absolute difference at most 1.0 of 255 per
/// channel, and 99% of pixels within 8 of 255 (the silhouette is about 1% of the pixels).
const TOLERANCE: ImageTolerance = ImageTolerance {
    mean_abs: 1.0,
    percentile: 99.0,
    max_at_percentile: 8,
};

#[test]
fn default_sphere_matches_the_reference_image() {
    let gpu = GpuTest::new();
    let (mesh, scene) = exitance_scene("sphere", 50.0, vec![Light::default_light()], 1.3);
    let frame = FrameDesc {
        width: 128,
        height: 128,
        ..FrameDesc::default()
    };
    let captured = render_headless(&gpu.ctx, &mesh, &scene, &frame).expect("render");
    let image = &captured.image;
    assert!(
        image.pixels.iter().flatten().all(|v| v.is_finite()),
        "NaN or Inf in the capture"
    );
    assert_eq!(
        image.pixel(0, 0),
        [0.0, 0.0, 0.0, 0.0],
        "background must be black (0)"
    );
    let centre = image.pixel(64, 64);
    assert!(centre[0] > 0.1, "the sphere's centre is lit: {centre:?}");
    for pass in ["shadow_map", "shading", "capture"] {
        assert!(
            captured
                .passes
                .get(pass)
                .is_some_and(|ms| ms.is_finite() && *ms >= 0.0),
            "{pass}: {:?}",
            captured.passes
        );
    }
    let reference = workspace_root().join("tests/reference/default_sphere_128.png");
    let diff = compare_to_reference(
        "default_sphere_128",
        128,
        128,
        &image.to_srgb8(1.0),
        &reference,
        TOLERANCE,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    println!("{diff:?}");
    gpu.finish();
}

#[test]
fn uniform_exitance_gives_the_exact_fresnel_radiance_at_normal_view() {
    let gpu = GpuTest::new();
    let eta = 1.3;
    let (mut mesh, scene) = exitance_scene("sphere", 50.0, vec![Light::default_light()], eta);
    let j = [0.8f32, 0.4, 0.2];
    mesh.exitance = vec![j; mesh.mesh.positions.len()];
    // The camera on the +Z axis: the centre pixel sees the sphere's normal (0, 0, 1) head on.
    let camera = translucent::scene::Camera {
        eye: glam::DVec3::new(0.0, 0.0, 200.0),
        target: glam::DVec3::ZERO,
        fovy_deg: 30.0,
    };
    let mut frame = FrameDesc {
        width: 64,
        height: 64,
        camera: Some(camera),
        specular: false,
        ..FrameDesc::default()
    };
    let physical = render_headless(&gpu.ctx, &mesh, &scene, &frame)
        .expect("render")
        .image
        .pixel(32, 32);
    frame.radiance = RadianceMode::Paper;
    let paper = render_headless(&gpu.ctx, &mesh, &scene, &frame)
        .expect("render")
        .image
        .pixel(32, 32);

    // The pixel centre's view ray is 0.23 degrees off the normal: F_t changes by < 1e-6 there.
    let f_t = 1.0 - translucent::material::fresnel::reflectance(eta, 1.0);
    for c in 0..3 {
        let expected_physical = f_t * f64::from(j[c]) / (std::f64::consts::PI * eta * eta);
        let expected_paper = f_t * f64::from(j[c]) / std::f64::consts::PI;
        // fp16 storage: relative error <= 2^-11, plus the interpolation of unit normals.
        for (got, want) in [(physical[c], expected_physical), (paper[c], expected_paper)] {
            assert!(
                (f64::from(got) - want).abs() <= want * 1e-3,
                "channel {c}: {got} vs {want}"
            );
        }
    }
    gpu.finish();
}

#[test]
fn consecutive_frames_are_identical_and_hazard_free() {
    // Frame 2 starts from the states frame 1 left (shadow map sampled, color copied, uniforms
    // read): synchronization validation checks those barriers.
    let gpu = GpuTest::new();
    let (mesh, scene) = exitance_scene("torus", 40.0, vec![Light::default_light()], 1.4);
    let frame = FrameDesc {
        width: 96,
        height: 64,
        ..FrameDesc::default()
    };
    let mut renderer = HeadlessRenderer::new(&gpu.ctx, &mesh, &scene, &frame).expect("renderer");
    let first = renderer.render_frame(&gpu.ctx).expect("frame 1");
    let second = renderer.render_frame(&gpu.ctx).expect("frame 2");
    assert!(second.frame > first.frame);
    assert_eq!(
        first.image, second.image,
        "the same scene must render the same pixels"
    );
    assert!(
        first.image.pixels.iter().any(|p| p[0] > 0.0),
        "the torus is visible"
    );
    drop(renderer);
    gpu.finish();
}

#[test]
fn specular_of_a_light_behind_the_camera_matches_cook_torrance_at_normal_view() {
    // Light travelling along -Z (from behind the camera), camera on +Z: at the centre pixel
    // n = v = l = h. With roughness 1 (GGX alpha = 1) D = 1/pi and G = 1, so the specular radiance
    // is F_r(eta, 0) E / (4 pi), independent of the small off-axis angle of the pixel centre.
    // The sphere is convex and the point faces the light: the shadow map must not shadow it
    // (this catches self-shadowing acne). Tolerance 1%: fp16 storage of ~0.15 plus the 0.03 rad
    // normal offset of the pixel centre (cos^2 = 0.9992).
    let gpu = GpuTest::new();
    let eta = 1.3;
    let irradiance = [100.0, 50.0, 25.0];
    let light = Light::Directional {
        direction: glam::DVec3::new(0.0, 0.0, -1.0),
        irradiance,
    };
    let (mut mesh, scene) = exitance_scene("sphere", 50.0, vec![light], eta);
    mesh.exitance = vec![[0.1; 3]; mesh.mesh.positions.len()];
    let camera = translucent::scene::Camera {
        eye: glam::DVec3::new(0.0, 0.0, 200.0),
        target: glam::DVec3::ZERO,
        fovy_deg: 30.0,
    };
    let mut frame = FrameDesc {
        width: 64,
        height: 64,
        camera: Some(camera),
        specular: true,
        roughness: 1.0,
        ..FrameDesc::default()
    };
    let with = render_headless(&gpu.ctx, &mesh, &scene, &frame)
        .expect("render")
        .image
        .pixel(32, 32);
    frame.specular = false;
    let without = render_headless(&gpu.ctx, &mesh, &scene, &frame)
        .expect("render")
        .image
        .pixel(32, 32);
    let f_r = translucent::material::fresnel::reflectance(eta, 1.0);
    for c in 0..3 {
        let expected = f_r * irradiance[c] / (4.0 * std::f64::consts::PI);
        let got = f64::from(with[c] - without[c]);
        assert!(
            (got - expected).abs() <= 0.01 * expected,
            "channel {c}: specular {got}, Cook-Torrance {expected}"
        );
    }
    gpu.finish();
}

#[test]
fn the_shadow_map_removes_the_specular_of_an_occluded_point_only() {
    // Torus in the XZ plane (major 14 mm, minor 6 mm), light travelling along -X, camera above
    // +X. The inner face of the far tube at P faces the light (n.l > 0) but the near tube hides
    // it: no specular there. Q on the outer face of the near tube is lit: its specular matches
    // Cook-Torrance (roughness 1: D = 1/pi, G = g1(n.l) g1(n.v) with g1(x) = 2x / (x + 1)) within
    // 5% (the pixel sees a point up to ~0.2 mm from Q, on a 48-segment triangulation).
    let gpu = GpuTest::new();
    let eta = 1.3;
    let irradiance = [100.0; 3];
    let light = Light::Directional {
        direction: glam::DVec3::new(-1.0, 0.0, 0.0),
        irradiance,
    };
    let (mut mesh, scene) = exitance_scene("torus", 40.0, vec![light], eta);
    mesh.exitance = vec![[0.1; 3]; mesh.mesh.positions.len()];
    let eye = glam::DVec3::new(30.0, 60.0, 0.0);
    let camera = translucent::scene::Camera {
        eye,
        target: glam::DVec3::new(6.0, 0.0, 0.0),
        fovy_deg: 50.0,
    };
    let size = 256u32;
    let mut frame = FrameDesc {
        width: size,
        height: size,
        camera: Some(camera),
        specular: true,
        roughness: 1.0,
        ..FrameDesc::default()
    };
    let with = render_headless(&gpu.ctx, &mesh, &scene, &frame)
        .expect("render")
        .image;
    frame.specular = false;
    let without = render_headless(&gpu.ctx, &mesh, &scene, &frame)
        .expect("render")
        .image;

    let (centre, radius) = mesh.bounding_sphere();
    let view_proj = camera.view_proj(1.0, centre, radius);
    let specular_at = |p: glam::DVec3| {
        let clip = view_proj * p.as_vec3().extend(1.0);
        let ndc = clip.truncate() / clip.w;
        let (x, y) = (
            ((ndc.x * 0.5 + 0.5) * size as f32) as u32,
            ((ndc.y * 0.5 + 0.5) * size as f32) as u32,
        );
        assert!(
            without.pixel(x, y)[0] > 0.0,
            "{p:?} is not visible at pixel ({x}, {y})"
        );
        f64::from(with.pixel(x, y)[0] - without.pixel(x, y)[0])
    };
    let cook_torrance = |p: glam::DVec3, n: glam::DVec3| {
        let l = glam::DVec3::X;
        let v = (eye - p).normalize();
        let h = (l + v).normalize();
        let g1 = |x: f64| 2.0 * x / (x + 1.0);
        let (n_l, n_v) = (n.dot(l), n.dot(v));
        translucent::material::fresnel::reflectance(eta, v.dot(h)) * g1(n_l) * g1(n_v)
            / (std::f64::consts::PI * 4.0 * n_l * n_v)
            * irradiance[0]
            * n_l
    };
    // Points on the tube circles at angle t above the equator, normal (cos t, sin t, 0).
    let on_tube = |tube_x: f64, t: f64| {
        let n = glam::DVec3::new(t.to_radians().cos(), t.to_radians().sin(), 0.0);
        (glam::DVec3::new(tube_x, 0.0, 0.0) + 6.0 * n, n)
    };
    let (q, n_q) = on_tube(14.0, 45.0);
    let (lit, expected) = (specular_at(q), cook_torrance(q, n_q));
    assert!(
        (lit - expected).abs() <= 0.05 * expected,
        "lit point Q: specular {lit}, Cook-Torrance {expected}"
    );
    // P at 30 degrees: the horizontal ray towards the light at y = 3 mm crosses the near tube.
    let (p, n_p) = on_tube(-14.0, 30.0);
    let (shadowed, unshadowed) = (specular_at(p), cook_torrance(p, n_p));
    assert!(
        shadowed.abs() <= 0.02 * unshadowed,
        "occluded point P: specular {shadowed} (unshadowed {unshadowed})"
    );
    gpu.finish();
}

#[test]
fn exitance_supplied_later_replaces_the_old_one() {
    // As a solver would: new J+ per vertex for the same mesh, here zero with no specular, which
    // must leave only the black background; a wrong length is refused.
    let gpu = GpuTest::new();
    let (mesh, scene) = exitance_scene("sphere", 50.0, vec![Light::default_light()], 1.3);
    let frame = FrameDesc {
        width: 32,
        height: 32,
        specular: false,
        ..FrameDesc::default()
    };
    let mut renderer = HeadlessRenderer::new(&gpu.ctx, &mesh, &scene, &frame).expect("renderer");
    let lit = renderer.render_frame(&gpu.ctx).expect("frame 1");
    assert!(lit.image.pixel(16, 16)[0] > 0.0);
    let zero = vec![[0.0f32; 3]; mesh.mesh.positions.len()];
    assert!(
        renderer.set_exitance(&gpu.ctx, &zero[1..]).is_err(),
        "one value per vertex"
    );
    renderer
        .set_exitance(&gpu.ctx, &zero)
        .expect("set exitance");
    let dark = renderer.render_frame(&gpu.ctx).expect("frame 2");
    assert!(
        dark.image.pixels.iter().all(|p| p[..3] == [0.0; 3]),
        "zero J+ gives zero radiance"
    );
    drop(renderer);
    gpu.finish();
}
