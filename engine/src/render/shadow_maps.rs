//! [`ShadowMaps`]: one depth map per shadow-casting light, all in one depth atlas, rendered from
//! the display mesh with dynamic rendering and slope-scaled depth bias (DESIGN section 5, first pass).
//!
//! Each light gets shadow views fitted to the object's bounding sphere:
//! - directional: one orthographic view covering the sphere;
//! - spot or point outside the sphere: one perspective view, the narrower of the spot's cone and
//!   the cone the sphere subtends from the light;
//! - a light close to or inside the sphere (the view would be wider than 60 degrees off axis):
//!   six 90-degree perspective faces of a cube around it.
//!
//! Every view is a square tile of one `D32_SFLOAT` atlas, so a compute shader samples all of
//! them through one binding ([`crate::render::IrradiancePass`] does 3x3 PCF inside the tile). With
//! no shadow-casting light nothing is recorded: no pass, no profiler scope.
//!
//! ```no_run
//! use glam::DVec3;
//! use translucent::render::{ShadowMaps, ShadowMapsDesc};
//! use translucent::mesh::GpuMesh;
//! # fn f(ctx: &translucent::vk::Context, mesh: &translucent::mesh::TriMesh, cb: ash::vk::CommandBuffer,
//! #      profiler: &mut translucent::vk::GpuProfiler) -> Result<(), translucent::Error> {
//! let mut shadows = ShadowMaps::new(ctx, &ShadowMapsDesc::default())?;
//! let lights = ["spot:0,60,0:0,-1,0:4000,4000,4000:20,30".parse()?];
//! shadows.set_lights(&lights, (DVec3::ZERO, 25.0), true)?;
//! let caster = GpuMesh::new(ctx, mesh, &vec![[0.0; 3]; mesh.positions.len()])?;
//! let mut frame = translucent::frame::FrameGraph::new(ctx);
//! frame.pass("shadow_map").uses(shadows.uses(&caster)).record(|p| {
//!     // SAFETY: inside a pass declaring `shadows.uses`.
//!     unsafe { shadows.record(p.ctx, p.cb, &caster) };
//!     Ok(())
//! });
//! // SAFETY: `cb` is recording outside a rendering scope; everything outlives its execution.
//! unsafe { frame.execute(cb, Some(profiler), false)? };
//! # Ok(()) }
//! ```

use ash::vk;
use glam::{DVec3, Mat4, Vec3};

use super::RenderError;
use crate::mesh::{GpuMesh, Vertex};
use crate::scene::Light;
use crate::shader::{GraphicsPipeline, GraphicsPipelineDesc, VertexAttribute};
use crate::vk::barrier::Use;
use crate::vk::{barrier, Access, Context, Image, ImageDesc};

/// Depth format of the atlas.
pub const SHADOW_ATLAS_FORMAT: vk::Format = vk::Format::D32_SFLOAT;
/// The shadow pass's slope-scaled depth bias (depth texels per texel of slope): against acne at
/// grazing angles. Single scattering reads surfaces from its own unbiased depth views instead.
pub const SHADOW_SLOPE_BIAS: f32 = 1.5;
/// Lights one [`ShadowMaps`] (and one irradiance gather) handles.
pub const MAX_LIGHTS: usize = 8;
/// Shadow views: every light a cube.
pub const MAX_SHADOW_VIEWS: usize = MAX_LIGHTS * 6;
/// Beyond this half-angle a single perspective view wastes most of its texels (and at 90 degrees
/// it fails): use the six cube faces instead.
const MAX_SINGLE_VIEW_HALF_ANGLE_DEG: f64 = 60.0;
const MIN_HALF_ANGLE_DEG: f64 = 0.1;

/// Push constants of `shadow_map/depth_only.vert`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadowPush {
    pub view_proj: [f32; 16],
}

/// How to create [`ShadowMaps`].
#[derive(Clone, Debug)]
pub struct ShadowMapsDesc {
    /// Texels across one view's square tile.
    pub tile_resolution: u32,
    /// Tiles in the atlas (a cube light takes 6); at most [`MAX_SHADOW_VIEWS`].
    pub max_views: u32,
}

impl Default for ShadowMapsDesc {
    fn default() -> Self {
        ShadowMapsDesc {
            tile_resolution: 512,
            max_views: 8,
        }
    }
}

/// One rendered view of one light: a tile of the atlas.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowView {
    /// Object frame (mm) to clip space, Vulkan depth 0..1; clip x, y in -1..1 map onto the tile.
    pub view_proj: Mat4,
    /// Atlas texel of the tile's top-left corner.
    pub origin: [u32; 2],
    /// Tile size in texels.
    pub size: u32,
    /// Orthographic views: world size (mm) of one texel; 0 for perspective views.
    pub texel_mm: f32,
    /// Perspective views: the eye (the light's position).
    pub eye: Vec3,
    /// Perspective views: world size of one texel per mm of distance from the eye; 0 otherwise.
    pub texel_per_mm: f32,
}

/// The shadow views of each light, in light order: `(first view, count)`; count 0: unshadowed.
pub type LightViews = Vec<(u32, u32)>;

/// Owns the depth atlas and the depth-only pipeline.
pub struct ShadowMaps {
    pipeline: GraphicsPipeline<ShadowPush>,
    /// The depth atlas (`D32_SFLOAT`), sampled by the irradiance gather and shading.
    pub atlas: Image,
    tile: u32,
    columns: u32,
    max_views: u32,
    views: Vec<ShadowView>,
    light_views: LightViews,
}

fn invalid(what: &str, problem: impl Into<String>) -> RenderError {
    RenderError::Invalid {
        what: what.into(),
        problem: problem.into(),
    }
}

/// An up vector not parallel to `forward`.
fn up_for(forward: DVec3) -> DVec3 {
    if forward.cross(DVec3::Y).length() < 1e-3 {
        DVec3::Z
    } else {
        DVec3::Y
    }
}

/// A perspective view from `eye` along `axis` with half-angle `half` (radians), depth range
/// covering the sphere (`centre`, `radius`); `None` if the sphere is entirely behind the eye.
fn perspective(
    eye: DVec3,
    axis: DVec3,
    half: f64,
    centre: DVec3,
    radius: f64,
) -> Option<(Mat4, f32)> {
    let along = (centre - eye).dot(axis);
    let far = along + radius;
    if far <= 0.0 {
        return None;
    }
    // Depth precision falls with far/near; 1e-3 keeps D32F's steps far below a texel.
    let near = (along - radius).max(far * 1e-3);
    let view = Mat4::look_at_rh(
        eye.as_vec3(),
        (eye + axis).as_vec3(),
        up_for(axis).as_vec3(),
    );
    let proj = Mat4::perspective_rh((2.0 * half) as f32, 1.0, near as f32, far as f32);
    Some((proj * view, (2.0 * half.tan()) as f32))
}

/// Appends the view(s) of one light (tile placement is filled in by the caller).
fn fit_views(
    light: &Light,
    centre: DVec3,
    radius: f64,
    tile_resolution: u32,
    views: &mut Vec<ShadowView>,
) {
    let tile = f64::from(tile_resolution);
    let ortho = |view_proj: Mat4, texel_mm: f64| ShadowView {
        view_proj,
        origin: [0, 0],
        size: 0,
        texel_mm: texel_mm as f32,
        eye: Vec3::ZERO,
        texel_per_mm: 0.0,
    };
    let persp = |eye: DVec3, (view_proj, tan2): (Mat4, f32)| ShadowView {
        view_proj,
        origin: [0, 0],
        size: 0,
        texel_mm: 0.0,
        eye: eye.as_vec3(),
        texel_per_mm: tan2 / tile_resolution as f32,
    };
    let (eye, cone) = match *light {
        Light::Directional { direction, .. } => {
            let d = direction.normalize();
            let eye = centre - d * 2.0 * radius;
            let view = Mat4::look_at_rh(eye.as_vec3(), centre.as_vec3(), up_for(d).as_vec3());
            let r = radius as f32;
            let proj = Mat4::orthographic_rh(-r, r, -r, r, 0.0, (4.0 * radius) as f32);
            views.push(ortho(proj * view, 2.0 * radius / tile));
            return;
        }
        Light::Point { position, .. } => (position, None),
        Light::Spot {
            position,
            direction,
            outer_deg,
            ..
        } => (
            position,
            Some((direction.normalize(), outer_deg.to_radians())),
        ),
    };
    let to_centre = centre - eye;
    let distance = to_centre.length();
    let max_half = MAX_SINGLE_VIEW_HALF_ANGLE_DEG.to_radians();
    // The cone the bounding sphere subtends from the light (none when the light is inside).
    let sphere = (distance > radius).then(|| (to_centre / distance, (radius / distance).asin()));
    let single = match (sphere, cone) {
        (Some((axis, a)), Some((_, outer))) if a <= outer => Some((axis, a)),
        (_, Some((axis, outer))) => Some((axis, outer)),
        (Some(s), None) => Some(s),
        (None, None) => None,
    };
    match single.filter(|&(_, half)| half <= max_half) {
        Some((axis, half)) => {
            // A zero cone (allowed, it lights only its axis) would give an infinite projection.
            let half = half.max(MIN_HALF_ANGLE_DEG.to_radians());
            if let Some(vp) = perspective(eye, axis, half, centre, radius) {
                views.push(persp(eye, vp));
            }
        }
        None => {
            // Cube faces in the order the gather's cube_face() picks them: +X -X +Y -Y +Z -Z.
            // Slightly wider than 90 degrees: PCF and the normal offset may step over an edge.
            let half = (1.0 + 4.0 / tile).atan();
            for axis in [
                DVec3::X,
                -DVec3::X,
                DVec3::Y,
                -DVec3::Y,
                DVec3::Z,
                -DVec3::Z,
            ] {
                // A face that sees none of the sphere still gets a tile (the gather indexes
                // faces by direction): any valid view, nothing is drawn into it.
                let vp = perspective(eye, axis, half, centre, radius).unwrap_or_else(|| {
                    perspective(eye, axis, half, eye + axis * radius, radius)
                        .unwrap_or((Mat4::IDENTITY, 2.0))
                });
                views.push(persp(eye, vp));
            }
        }
    }
}

impl ShadowMaps {
    pub fn new(ctx: &Context, desc: &ShadowMapsDesc) -> Result<ShadowMaps, RenderError> {
        if desc.tile_resolution < 16 {
            return Err(invalid(
                "shadow maps",
                format!(
                    "tile resolution {} is below 16 texels",
                    desc.tile_resolution
                ),
            ));
        }
        if desc.max_views == 0 || desc.max_views as usize > MAX_SHADOW_VIEWS {
            return Err(invalid(
                "shadow maps",
                format!(
                    "{} views: need 1..={MAX_SHADOW_VIEWS} (8 lights of 6 cube faces)",
                    desc.max_views
                ),
            ));
        }
        let columns = (f64::from(desc.max_views).sqrt().ceil() as u32).max(1);
        let rows = desc.max_views.div_ceil(columns);
        let pipeline = GraphicsPipeline::new(
            ctx,
            &GraphicsPipelineDesc {
                name: "shadow map",
                vertex: "shadow_map/depth_only.vert",
                fragment: None,
                vertex_stride: std::mem::size_of::<Vertex>() as u32,
                vertex_attributes: &[VertexAttribute {
                    location: 0,
                    format: vk::Format::R32G32B32_SFLOAT,
                    offset: 0,
                }],
                extra_streams: &[],
                color_formats: &[],
                depth_format: Some(SHADOW_ATLAS_FORMAT),
                // Slope-scaled bias against acne on surfaces seen at grazing angles; the gather adds
                // a normal offset for the rest.
                depth_bias: Some((1.0, SHADOW_SLOPE_BIAS)),
                cull_mode: vk::CullModeFlags::NONE,
                bindings: &[],
                max_sets: 1,
            },
        )?;
        let atlas = Image::new(
            ctx,
            &ImageDesc {
                name: "shadow atlas",
                width: columns * desc.tile_resolution,
                height: rows * desc.tile_resolution,
                format: SHADOW_ATLAS_FORMAT,
                // TRANSFER_SRC: the atlas can be captured for checks and debugging.
                usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT
                    | vk::ImageUsageFlags::SAMPLED
                    | vk::ImageUsageFlags::TRANSFER_SRC,
            },
        )?;
        // The gather's and the shading's descriptors name the atlas in a read-only depth layout
        // even while no light samples it: put it there once (a first shadow pass moves it on).
        ctx.execute("shadow atlas layout", |cb| {
            // SAFETY: `cb` is recording; the atlas outlives the waited submission.
            unsafe {
                // why: first use: UNDEFINED -> the sampled layout the descriptors name.
                barrier::image(
                    ctx,
                    cb,
                    &atlas,
                    Access::Undefined,
                    Access::DepthSampledShaders,
                )
            };
            Ok(())
        })?;
        Ok(ShadowMaps {
            pipeline,
            atlas,
            tile: desc.tile_resolution,
            columns,
            max_views: desc.max_views,
            views: Vec::new(),
            light_views: Vec::new(),
        })
    }

    /// Fits shadow views for `lights` around the object's bounding sphere `bounds` (centre,
    /// radius in mm). `cast_shadows = false` (or a black light) gives a light no view. Too many
    /// lights or views is a typed error, and leaves the previous views in place.
    pub fn set_lights(
        &mut self,
        lights: &[Light],
        bounds: (DVec3, f64),
        cast_shadows: bool,
    ) -> Result<(), RenderError> {
        let (centre, radius) = bounds;
        if !(centre.is_finite() && radius.is_finite() && radius > 0.0) {
            return Err(invalid(
                "shadow maps",
                format!("bounding sphere {centre}, {radius} mm is not finite and positive"),
            ));
        }
        if lights.len() > MAX_LIGHTS {
            return Err(invalid(
                "lights",
                format!(
                    "{} lights; at most {MAX_LIGHTS} are supported",
                    lights.len()
                ),
            ));
        }
        // A margin so PCF and the normal offset near the silhouette stay inside the tile.
        let radius = radius * 1.02;
        let mut views = Vec::new();
        let mut light_views = Vec::new();
        for light in lights {
            light.validate()?;
            let first = views.len() as u32;
            let black = match *light {
                Light::Directional { irradiance: c, .. }
                | Light::Point { intensity: c, .. }
                | Light::Spot { intensity: c, .. } => c.iter().all(|&v| v == 0.0),
            };
            if cast_shadows && !black {
                fit_views(light, centre, radius, self.tile, &mut views);
            }
            light_views.push((first, views.len() as u32 - first));
        }
        if views.len() > self.max_views as usize {
            return Err(invalid(
                "shadow maps",
                format!(
                    "the lights need {} shadow views, the atlas holds {} (ShadowMapsDesc::max_views)",
                    views.len(),
                    self.max_views
                ),
            ));
        }
        for (i, v) in views.iter_mut().enumerate() {
            let i = i as u32;
            v.origin = [
                (i % self.columns) * self.tile,
                (i / self.columns) * self.tile,
            ];
            v.size = self.tile;
        }
        self.views = views;
        self.light_views = light_views;
        Ok(())
    }

    /// Puts back views saved from [`ShadowMaps::views`] and [`ShadowMaps::light_views`] (undoing a
    /// `set_lights` whose scene was then refused elsewhere).
    pub fn restore(&mut self, (views, light_views): (Vec<ShadowView>, Vec<(u32, u32)>)) {
        self.views = views;
        self.light_views = light_views;
    }

    /// Texels across one view's square tile.
    pub fn tile_resolution(&self) -> u32 {
        self.tile
    }

    /// Tiles the atlas holds ([`ShadowMapsDesc::max_views`]).
    pub fn max_views(&self) -> u32 {
        self.max_views
    }

    /// The views of the current lights, in atlas order.
    pub fn views(&self) -> &[ShadowView] {
        &self.views
    }

    /// Per light of the last [`ShadowMaps::set_lights`]: (first view, view count).
    pub fn light_views(&self) -> &[(u32, u32)] {
        &self.light_views
    }

    /// `view`'s projection onto the whole atlas: clip x, y in -1..1 cover the atlas, the view's
    /// tile where it used to cover -1..1. For a sampler over the whole atlas that computes
    /// `uv = ndc.xy * 0.5 + 0.5` (as `mesh/shade_mesh.frag` does for its shadow lookup).
    pub fn atlas_view_proj(&self, view: usize) -> Option<Mat4> {
        let v = self.views.get(view)?;
        let (w, h) = (self.atlas.width as f32, self.atlas.height as f32);
        let (sx, sy) = (v.size as f32 / w, v.size as f32 / h);
        // ndc' = s ndc + (2 origin / extent + s - 1), applied to clip coordinates (times w).
        let bx = 2.0 * v.origin[0] as f32 / w + sx - 1.0;
        let by = 2.0 * v.origin[1] as f32 / h + sy - 1.0;
        let tile = Mat4::from_cols(
            glam::Vec4::new(sx, 0.0, 0.0, 0.0),
            glam::Vec4::new(0.0, sy, 0.0, 0.0),
            glam::Vec4::new(0.0, 0.0, 1.0, 0.0),
            glam::Vec4::new(bx, by, 0.0, 1.0),
        );
        Some(tile * v.view_proj)
    }

    /// Whether any light casts a shadow (otherwise [`ShadowMaps::record`] records no pass).
    pub fn any_shadows(&self) -> bool {
        !self.views.is_empty()
    }

    /// What [`Self::record`] uses: the atlas as depth attachment, `mesh`'s vertices.
    pub fn uses<'a>(&'a self, mesh: &'a GpuMesh) -> [Use<'a>; 2] {
        [
            Use::image(&self.atlas, Access::DepthAttachmentWrite),
            Use::buffer(mesh.vertex_buffer(), Access::VertexInput),
        ]
    }

    /// Renders `mesh`'s depth into every view's tile (nothing without shadow-casting lights).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::uses`]; `mesh` and `self` must outlive it.
    pub unsafe fn record(&self, ctx: &Context, cb: vk::CommandBuffer, mesh: &GpuMesh) {
        if self.views.is_empty() {
            return;
        }
        let extent = self.atlas.extent();
        // Only the tiles in use are cleared and drawn: the atlas is sized for the most views.
        let used = self.views.len() as u32;
        let area = vk::Extent2D {
            width: used.min(self.columns) * self.tile,
            height: used.div_ceil(self.columns) * self.tile,
        };
        let depth = vk::RenderingAttachmentInfo::default()
            .image_view(self.atlas.view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
            });
        let rendering = vk::RenderingInfo::default()
            .render_area(vk::Rect2D {
                offset: vk::Offset2D::default(),
                extent: area,
            })
            .layer_count(1)
            .depth_attachment(&depth);
        // SAFETY: the caller's contract; the pipeline's formats match the rendering scope.
        unsafe {
            ctx.raw().cmd_begin_rendering(cb, &rendering);
            for v in &self.views {
                let push = ShadowPush {
                    view_proj: v.view_proj.to_cols_array(),
                };
                self.pipeline
                    .bind(ctx, cb, vk::DescriptorSet::null(), &push, extent);
                let tile = vk::Rect2D {
                    offset: vk::Offset2D {
                        x: v.origin[0] as i32,
                        y: v.origin[1] as i32,
                    },
                    extent: vk::Extent2D {
                        width: v.size,
                        height: v.size,
                    },
                };
                ctx.raw().cmd_set_viewport(
                    cb,
                    0,
                    &[vk::Viewport {
                        x: v.origin[0] as f32,
                        y: v.origin[1] as f32,
                        width: v.size as f32,
                        height: v.size as f32,
                        min_depth: 0.0,
                        max_depth: 1.0,
                    }],
                );
                // The scissor keeps geometry clipped to this tile out of its neighbours.
                ctx.raw().cmd_set_scissor(cb, 0, &[tile]);
                mesh.draw(ctx, cb);
            }
            ctx.raw().cmd_end_rendering(cb);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A CPU stand-in for the views' projections: where a point lands in clip space.
    fn ndc(m: Mat4, p: DVec3) -> Vec3 {
        let c = m * p.as_vec3().extend(1.0);
        c.truncate() / c.w
    }

    #[test]
    fn views_cover_the_bounding_sphere() {
        // No GPU: `fit` only needs the tile size, so build the views through a bare struct.
        let (centre, radius) = (DVec3::new(1.0, 2.0, 3.0), 10.0);
        let lights: [Light; 4] = [
            "dir:1,-0.2,0:1,1,1".parse().expect("light"),
            "point:40,20,0:1,1,1".parse().expect("light"),
            "spot:0,50,3:0,-1,0:1,1,1:5,10".parse().expect("light"),
            "point:1,2,3:1,1,1".parse().expect("light"),
        ];
        let counts = [1, 1, 1, 6];
        let sphere_points: Vec<DVec3> = (0..200)
            .map(|i| {
                let z = -1.0 + 2.0 * (i as f64 + 0.5) / 200.0;
                let phi = i as f64 * 2.399_963;
                let s = (1.0 - z * z).sqrt();
                centre + radius * DVec3::new(s * phi.cos(), s * phi.sin(), z)
            })
            .collect();
        for (light, count) in lights.iter().zip(counts) {
            let mut views = Vec::new();
            fit_views(light, centre, radius, 256, &mut views);
            assert_eq!(views.len(), count, "{light:?}");
            if count == 1 {
                let spot_narrow = matches!(light, Light::Spot { .. });
                for p in &sphere_points {
                    let q = ndc(views[0].view_proj, *p);
                    if spot_narrow {
                        // A 10-degree spot covers less than the sphere: only its cone is in view.
                        continue;
                    }
                    assert!(
                        q.x.abs() <= 1.0 && q.y.abs() <= 1.0 && (0.0..=1.0).contains(&q.z),
                        "{light:?}: {p} -> {q}"
                    );
                }
            } else {
                // Every direction from the light lands inside the face its major axis picks.
                for p in &sphere_points {
                    let d = *p - centre;
                    let a = d.abs();
                    let face = if a.x >= a.y && a.x >= a.z {
                        usize::from(d.x < 0.0)
                    } else if a.y >= a.z {
                        2 + usize::from(d.y < 0.0)
                    } else {
                        4 + usize::from(d.z < 0.0)
                    };
                    let q = ndc(views[face].view_proj, *p);
                    assert!(
                        q.x.abs() <= 1.0 && q.y.abs() <= 1.0 && (0.0..=1.0).contains(&q.z),
                        "face {face}: {p} -> {q}"
                    );
                }
            }
        }
    }

    #[test]
    fn degenerate_cones_and_far_faces_give_finite_views() {
        let (centre, radius) = (DVec3::ZERO, 10.0);
        for light in [
            "spot:0,50,0:0,-1,0:1,1,1:0,0",
            "spot:0,50,0:0,1,0:1,1,1:5,10",
            "point:0,11,0:1,1,1",
            "spot:0,0,0:0,1,0:1,1,1:80,90",
        ] {
            let light: Light = light.parse().expect("light");
            let mut views = Vec::new();
            fit_views(&light, centre, radius, 64, &mut views);
            for v in &views {
                assert!(
                    v.view_proj.is_finite() && v.texel_per_mm.is_finite() && v.texel_mm.is_finite(),
                    "{light:?}: {v:?}"
                );
            }
        }
    }
}
