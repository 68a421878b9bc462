//! The shadow atlas's depth pass (the one the shading pass's specular shadow and the irradiance
//! gather both read; the separate `ShadowPass` is gone) against the analytic depth of a sphere
//! seen from a directional light.
//!
//! `ShadowMaps::set_lights` fits an orthographic view along the light direction d to the bounding
//! sphere grown by 2% (r' = 1.02 r, r: bounding radius): the eye sits 2r' before the centre, near
//! 0, far 4r'. The sphere's point nearest to the light is at distance 2r' - R from the eye, so the
//! map's centre texel holds (2r' - R) / 4r' = 1.04 / 4.08 = 0.2549 for R = r. Tolerance 1e-3: the
//! 64-segment triangulation lies inside the sphere by at most R (1 - cos(pi/128)) = 3e-4 R, i.e.
//! 8e-5 in depth; depth bias and texel offset add less than 1e-5. Texels outside the silhouette
//! keep the clear value 1.

use translucent::frame::{FrameGraph, PASS_SHADOW};
use translucent::mesh::GpuMesh;
use translucent::render::{ShadowMaps, ShadowMapsDesc};
use translucent::scene::Light;
use translucent::vk::{Access, ImageReadback};
use translucent_tests::{exitance_scene, GpuTest};

#[test]
fn shadow_map_holds_the_analytic_depth_of_a_sphere() {
    let gpu = GpuTest::new();
    let ctx = &gpu.ctx;
    let (object, scene) = exitance_scene("sphere", 50.0, vec![Light::default_light()], 1.3);
    let mesh = GpuMesh::new(ctx, &object.mesh, &object.exitance).expect("mesh");
    let mut shadow = ShadowMaps::new(
        ctx,
        &ShadowMapsDesc {
            tile_resolution: 128,
            max_views: 1,
        },
    )
    .expect("shadow maps");
    shadow
        .set_lights(&scene.lights, object.bounding_sphere(), true)
        .expect("one directional light");
    assert_eq!(shadow.views().len(), 1);
    assert_eq!((shadow.atlas.width, shadow.atlas.height), (128, 128));
    ctx.execute("depth pass", |cb| {
        let mut graph = FrameGraph::new(ctx);
        let (shadow, mesh) = (&shadow, &mesh);
        graph
            .pass(PASS_SHADOW)
            .uses(shadow.uses(mesh))
            .record(move |p| {
                // SAFETY: inside the pass declaring the shadow maps' uses; mesh and maps outlive
                // the waited submission.
                unsafe { shadow.record(p.ctx, p.cb, mesh) };
                Ok(())
            });
        // SAFETY: `cb` is recording outside a rendering scope; everything outlives the wait.
        unsafe { graph.execute(cb, None, false) }.expect("frame graph");
        Ok(())
    })
    .expect("render");
    // The graph left the atlas in its last use's state, the depth attachment.
    assert_eq!(
        shadow.atlas.tracked().layout,
        ash::vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL
    );
    let depth = ImageReadback::capture(ctx, &shadow.atlas, Access::DepthAttachmentWrite)
        .expect("read back");

    // Texel (64, 64) is centred 0.5 texel off the axis: on a 128-texel map spanning 2.04 r that
    // moves the surface by less than 1e-5 in depth.
    let expected = (2.0 * 1.02 - 1.0) / (4.0 * 1.02);
    let centre = depth.pixel(64, 64)[0];
    assert!(
        (centre - expected).abs() < 1e-3,
        "centre depth {centre}, expected {expected}"
    );
    for (x, y) in [(0, 0), (127, 0), (0, 127), (127, 127)] {
        assert_eq!(
            depth.pixel(x, y)[0],
            1.0,
            "corner ({x}, {y}) is outside the sphere"
        );
    }
    // Depth grows from the centre towards the silhouette (the sphere curves away from the light).
    let row: Vec<f32> = (64..128).map(|x| depth.pixel(x, 64)[0]).collect();
    let inside: Vec<f32> = row.iter().copied().take_while(|&d| d < 1.0).collect();
    assert!(
        inside.len() > 50,
        "the sphere covers about 99% of the map's half-width"
    );
    assert!(inside.windows(2).all(|w| w[1] >= w[0] - 1e-6), "{inside:?}");
    drop((mesh, shadow));
    gpu.finish();
}
