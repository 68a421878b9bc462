//! A headless wgpu program embedding a translucent object (`translucent::interop::wgpu`):
//!
//! ```text
//! cargo run --release --example wgpu_host [OUT.png]              # default target/wgpu_host.png
//! TRANSLUCENT_VALIDATION=1 cargo run --release --example wgpu_host  # exits 1 on any message
//! ```
//!
//! wgpu owns the instance, device and queue (opened by `create_device`, which asks wgpu-hal for the
//! Vulkan 1.3 features we record with). Every frame is three command buffers in one submission:
//! 1. the host's background pass (wgpu): a sky gradient, a floor band, and a dark pillar standing
//!    in front of the object, drawn with the object's own camera matrix so its depth is
//!    comparable: the object is depth-tested against it;
//! 2. our object, recorded by `WgpuContext::record_object` into a command buffer of its own (wgpu
//!    encodes its passes when an encoder is finished, so raw Vulkan work cannot share one);
//! 3. the host's overlay pass (wgpu): a translucent white band blended over everything, then (last
//!    frame) a copy of the HDR target into a buffer that is read back.
//!
//! Frames: 1 a cold solve (light turned by 40 degrees), 2 the light back (a warm-started solve),
//! 3 the camera moved (shading only), 4 the camera back (shading only); frame 4 is written as PNG
//! and is the scene `translucent render` draws with the command this program prints.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use glam::{DVec3, Mat4, Vec3};
use translucent::interop::wgpu::{create_device, vk_format, WgpuContext, WgpuDesc, WgpuTargets};
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::object::CompletedSolve;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Camera, Environment, Light, Scene};
use translucent::solver::gpu::GpuSolveParams;
use translucent::vk::{GpuProfiler, LinearImage};
use translucent::{FrameReport, ObjectParams, QuadGraph, TranslucentObject};
use wgpu::util::DeviceExt as _;

pub const WIDTH: u32 = 160;
pub const HEIGHT: u32 = 120;
/// The object: `translucent render --shape torus --size-mm 30 --resolution 20 --levels 2`.
pub const SIZE_MM: f64 = 30.0;
pub const RESOLUTION: u32 = 20;
pub const LEVELS: u32 = 2;
pub const MATERIAL: &str = "marble";
/// The solve's stopping tolerance (`translucent render`'s default).
pub const TOLERANCE: f32 = 1e-4;
pub const HDR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Linear colours of the host's passes.
pub const SKY_TOP: [f32; 3] = [0.02, 0.03, 0.08];
pub const SKY_BOTTOM: [f32; 3] = [0.10, 0.12, 0.20];
pub const FLOOR: [f32; 3] = [0.12, 0.10, 0.08];
pub const PILLAR: [f32; 3] = [0.03, 0.02, 0.02];
/// The overlay: white at this alpha, blended over rows `OVERLAY_ROWS`.
pub const OVERLAY_ALPHA: f32 = 0.25;
pub const OVERLAY_ROWS: std::ops::Range<u32> = 70..80;
/// The pillar: a vertical board in front of the torus (mm, in the object's frame).
const PILLAR_X: [f32; 2] = [-9.0, -6.0];
const PILLAR_Y: [f32; 2] = [-20.0, 20.0];
const PILLAR_Z: f32 = 20.0;
/// Exposure of the written PNG.
pub const EXPOSURE: f32 = 1.5;

/// The light of the compared frames and the one frame 1 starts from.
pub fn light(turned: bool) -> Light {
    let base = Light::Directional {
        direction: DVec3::new(0.3, -0.8, -0.5).normalize(),
        irradiance: [4.0; 3],
    };
    if turned {
        base.rotated(glam::DQuat::from_rotation_y(40f64.to_radians()))
    } else {
        base
    }
}

pub fn scene(turned: bool) -> Scene {
    Scene {
        lights: vec![light(turned)],
        environment: Environment::Constant([0.05, 0.05, 0.06]),
    }
}

/// The compared camera, and the one frame 3 moves to.
pub fn camera(moved: bool) -> Camera {
    Camera {
        eye: if moved {
            DVec3::new(25.0, 20.0, 55.0)
        } else {
            DVec3::new(0.0, 20.0, 60.0)
        },
        target: DVec3::ZERO,
        fovy_deg: 30.0,
    }
}

pub fn material() -> MaterialField {
    MaterialField::Homogeneous(Material::preset(MATERIAL).expect("a preset"))
}

/// The torus as `translucent render --shape torus` builds it.
pub fn graph() -> Result<QuadGraph, translucent::Error> {
    let torus = Shape::Torus {
        major: 0.35 * SIZE_MM,
        minor: 0.15 * SIZE_MM,
    };
    let bake = BakeParams {
        resolution: RESOLUTION,
        levels: LEVELS,
        ..BakeParams::default()
    };
    Ok(QuadGraph::bake(&torus.triangulate(96), &torus, &bake, &mut |_| {})?.0)
}

/// The object's parameters as `translucent render` sets them, for the given target formats.
pub fn object_params(color: ash::vk::Format, depth: ash::vk::Format) -> ObjectParams {
    ObjectParams {
        solve: GpuSolveParams {
            iterations: vec![2000],
            tolerance: TOLERANCE,
            ..GpuSolveParams::default()
        },
        color_format: color,
        depth_format: depth,
        // The library's default is the real-time one (multigrid, second-collision source, single
        // scattering); this host pins the cascade, the boundary flux and no single scattering
        // that `render_command` names.
        single_scattering: None,
        ..ObjectParams::default()
    }
}

/// The `translucent render` command of the compared frame.
pub fn render_command() -> String {
    let Light::Directional {
        direction: d,
        irradiance: e,
    } = light(false)
    else {
        unreachable!("a directional light")
    };
    let Environment::Constant(env) = scene(false).environment else {
        unreachable!("a constant environment")
    };
    let c = camera(false);
    format!(
        "translucent render --shape torus --size-mm {SIZE_MM} --resolution {RESOLUTION} --levels {LEVELS} \
         --material {MATERIAL} --light dir:{},{},{}:{},{},{} --env-constant {},{},{} \
         --camera {},{},{}:{},{},{}:{} --width {WIDTH} --height {HEIGHT} \
         --schedule cascade --source flux --single-scattering off --bounce off \
         --supersample 1 --out reference.exr",
        d.x, d.y, d.z, e[0], e[1], e[2], env[0], env[1], env[2], c.eye.x, c.eye.y, c.eye.z,
        c.target.x, c.target.y, c.target.z, c.fovy_deg
    )
}

/// What one run produced.
pub struct Outcome {
    /// Khronos validation messages (with synchronization validation).
    pub validation: Vec<String>,
    /// Errors wgpu's own validation reported.
    pub wgpu_errors: Vec<String>,
    pub reports: Vec<FrameReport>,
    /// Every solve's iterations, once it completed.
    pub solves: Vec<CompletedSolve>,
    /// GPU ms per pass of each frame (our passes, from the profiler).
    pub timings: Vec<(u64, BTreeMap<String, f64>)>,
    /// The last frame, linear radiance as the host's HDR target holds it.
    pub image: LinearImage,
}

const SHADERS: &str = r#"
@group(0) @binding(0) var<uniform> pillar: mat4x4f;

struct Sky { @builtin(position) position: vec4f, @location(0) v: f32 }
@vertex fn sky_vs(@builtin(vertex_index) i: u32) -> Sky {
    let uv = vec2f(f32((i << 1u) & 2u), f32(i & 2u));
    var out: Sky;
    out.position = vec4f(uv * 2.0 - 1.0, 1.0, 1.0);
    out.v = 1.0 - uv.y; // 0 at the top of the image, 1 at the bottom
    return out;
}
@fragment fn sky_fs(in: Sky) -> @location(0) vec4f {
    if in.v > 0.75 { return vec4f($FLOOR, 1.0); }
    return vec4f(mix($SKY_TOP, $SKY_BOTTOM, in.v / 0.75), 1.0);
}

@vertex fn pillar_vs(@location(0) p: vec3f) -> @builtin(position) vec4f {
    return pillar * vec4f(p, 1.0);
}
@fragment fn pillar_fs() -> @location(0) vec4f { return vec4f($PILLAR, 1.0); }

@vertex fn overlay_vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4f {
    let corner = array(vec2f(0.0, 0.0), vec2f(1.0, 0.0), vec2f(0.0, 1.0),
                       vec2f(0.0, 1.0), vec2f(1.0, 0.0), vec2f(1.0, 1.0))[i];
    return vec4f(mix($OVERLAY_LOW, $OVERLAY_HIGH, corner), 0.0, 1.0);
}
@fragment fn overlay_fs() -> @location(0) vec4f { return vec4f(1.0, 1.0, 1.0, $OVERLAY_ALPHA); }
"#;

fn wgsl_vec3(c: [f32; 3]) -> String {
    format!("vec3f({:?}, {:?}, {:?})", c[0], c[1], c[2])
}

/// The host's shaders with its constants substituted.
fn shader_source() -> String {
    let ndc_y = |row: u32| 1.0 - 2.0 * row as f32 / HEIGHT as f32;
    SHADERS
        .replace("$SKY_TOP", &wgsl_vec3(SKY_TOP))
        .replace("$SKY_BOTTOM", &wgsl_vec3(SKY_BOTTOM))
        .replace("$FLOOR", &wgsl_vec3(FLOOR))
        .replace("$PILLAR", &wgsl_vec3(PILLAR))
        .replace(
            "$OVERLAY_LOW",
            &format!("vec2f(-1.0, {:?})", ndc_y(OVERLAY_ROWS.end)),
        )
        .replace(
            "$OVERLAY_HIGH",
            &format!("vec2f(1.0, {:?})", ndc_y(OVERLAY_ROWS.start)),
        )
        .replace("$OVERLAY_ALPHA", &format!("{OVERLAY_ALPHA:?}"))
}

/// The pillar's clip-space matrix: the object's own view-projection (so the two depths compare),
/// with its Vulkan y flip undone for wgpu's y-up clip space.
fn pillar_matrix(camera: &Camera, graph: &QuadGraph) -> Mat4 {
    let (centre, radius) = graph.finest().bounding_sphere();
    let aspect = f64::from(WIDTH) / f64::from(HEIGHT);
    Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0)) * camera.view_proj(aspect, centre, radius)
}

/// Runs the host: 4 frames, the last one read back and written to `out` as PNG.
pub fn run(out: &Path, validation: bool) -> Result<Outcome, Box<dyn std::error::Error>> {
    let host = create_device(&WgpuDesc {
        validation,
        echo_validation: true,
        ..WgpuDesc::default()
    })?;
    let (device, queue) = (&host.device, &host.queue);
    let wgpu_errors = Arc::new(Mutex::new(Vec::new()));
    {
        let errors = wgpu_errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            eprintln!("wgpu: {e}");
            errors
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(e.to_string());
        }));
    }
    // SAFETY: this host is single-threaded: nothing else submits while objects are created.
    let ctx = unsafe { WgpuContext::new(device, queue, 2)? };
    let graph = Arc::new(graph()?);
    let mut object = TranslucentObject::new(
        &ctx,
        graph.clone(),
        &material(),
        &scene(true),
        &object_params(vk_format(HDR)?, vk_format(DEPTH)?),
    )?;
    let mut profiler = GpuProfiler::new(&ctx, "wgpu host", 4096)?;

    // The host's resources.
    let size = wgpu::Extent3d {
        width: WIDTH,
        height: HEIGHT,
        depth_or_array_layers: 1,
    };
    let texture = |label, format, usage| {
        device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size,
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let hdr = texture(
        "host hdr",
        HDR,
        wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
    );
    let depth = texture("host depth", DEPTH, wgpu::TextureUsages::RENDER_ATTACHMENT);
    let hdr_view = hdr.create_view(&Default::default());
    let depth_view = depth.create_view(&Default::default());
    let row_bytes = WIDTH * 8; // RGBA16F; 1280, a multiple of wgpu's 256-byte row alignment
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("host readback"),
        size: u64::from(row_bytes * HEIGHT),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let [x0, x1] = PILLAR_X;
    let [y0, y1] = PILLAR_Y;
    let corners: [[f32; 3]; 6] = [
        [x0, y0, PILLAR_Z],
        [x1, y0, PILLAR_Z],
        [x0, y1, PILLAR_Z],
        [x0, y1, PILLAR_Z],
        [x1, y0, PILLAR_Z],
        [x1, y1, PILLAR_Z],
    ];
    let pillar_vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("pillar vertices"),
        contents: bytemuck::cast_slice(&corners),
        usage: wgpu::BufferUsages::VERTEX,
    });
    let pillar_uniform = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("pillar matrix"),
        size: 64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("host passes"),
        source: wgpu::ShaderSource::Wgsl(shader_source().into()),
    });
    let bind_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("pillar"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }],
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("pillar"),
        layout: &bind_layout,
        entries: &[wgpu::BindGroupEntry {
            binding: 0,
            resource: pillar_uniform.as_entire_binding(),
        }],
    });
    let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("host passes"),
        bind_group_layouts: &[&bind_layout],
        push_constant_ranges: &[],
    });
    let pipeline = |label, vs, fs, vertex: &[wgpu::VertexBufferLayout<'_>], depth, blend| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some(vs),
                compilation_options: Default::default(),
                buffers: vertex,
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: depth,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some(fs),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: HDR,
                    blend,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview: None,
            cache: None,
        })
    };
    let depth_state = |compare, write| wgpu::DepthStencilState {
        format: DEPTH,
        depth_write_enabled: write,
        depth_compare: compare,
        stencil: Default::default(),
        bias: Default::default(),
    };
    let sky = pipeline(
        "sky",
        "sky_vs",
        "sky_fs",
        &[],
        Some(depth_state(wgpu::CompareFunction::Always, false)),
        None,
    );
    let pillar = pipeline(
        "pillar",
        "pillar_vs",
        "pillar_fs",
        &[wgpu::VertexBufferLayout {
            array_stride: 12,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &wgpu::vertex_attr_array![0 => Float32x3],
        }],
        Some(depth_state(wgpu::CompareFunction::Less, true)),
        None,
    );
    let overlay = pipeline(
        "overlay",
        "overlay_vs",
        "overlay_fs",
        &[],
        None,
        Some(wgpu::BlendState::ALPHA_BLENDING),
    );

    // Frames: (lights turned, camera moved).
    let frames = [(true, false), (false, false), (false, true), (false, false)];
    let mut reports = Vec::new();
    let mut solves = Vec::new();
    let mut timings = Vec::new();
    for (i, &(turned, moved)) in frames.iter().enumerate() {
        if i > 0 && turned != frames[i - 1].0 {
            object.set_lights(&scene(turned))?;
        }
        object.set_camera(Some(camera(moved)))?;
        queue.write_buffer(
            &pillar_uniform,
            0,
            bytemuck::bytes_of(&pillar_matrix(&camera(moved), &graph).to_cols_array()),
        );

        // 1. The host's background.
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("host background"),
        });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("background"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &hdr_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
            });
            pass.set_bind_group(0, &bind_group, &[]);
            pass.set_pipeline(&sky);
            pass.draw(0..3, 0..1);
            pass.set_pipeline(&pillar);
            pass.set_vertex_buffer(0, pillar_vertices.slice(..));
            pass.draw(0..6, 0..1);
        }
        let background = encoder.finish();

        // 2. Our object, in a command buffer of its own.
        let (ours, report) = ctx.record_object(
            &mut object,
            &WgpuTargets {
                color: &hdr_view,
                depth: Some(&depth_view),
            },
            Some(&mut profiler),
        )?;
        solves.extend(report.completed.iter().cloned());
        reports.push(report);

        // 3. The host's overlay, and the read-back of the last frame.
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("host overlay"),
        });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("overlay"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &hdr_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
            });
            pass.set_bind_group(0, &bind_group, &[]);
            pass.set_pipeline(&overlay);
            pass.draw(0..6, 0..1);
        }
        if i + 1 == frames.len() {
            encoder.copy_texture_to_buffer(
                hdr.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: &readback,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row_bytes),
                        rows_per_image: Some(HEIGHT),
                    },
                },
                size,
            );
        }
        queue.submit([background, ours, encoder.finish()]);
    }

    // Read the last frame back (the poll runs wgpu's callbacks: every frame completes).
    let slice = readback.slice(..);
    slice.map_async(wgpu::MapMode::Read, |r| {
        if let Err(e) = r {
            eprintln!("wgpu_host: mapping the read-back failed: {e}");
        }
    });
    device.poll(wgpu::PollType::wait_indefinitely())?;
    let pixels: Vec<[f32; 4]> = {
        let bytes = slice.get_mapped_range();
        bytemuck::cast_slice::<u8, [half::f16; 4]>(&bytes)
            .iter()
            .map(|p| p.map(f32::from))
            .collect()
    };
    readback.unmap();
    let image = LinearImage {
        width: WIDTH,
        height: HEIGHT,
        pixels,
    };
    let (_, completed) = ctx.frames();
    solves.extend(object.completed_solves(completed)?);
    profiler.frame_completed(completed);
    timings.extend(
        profiler
            .take_results()
            .into_iter()
            .map(|t| (t.frame, t.passes())),
    );
    image.write_png(out, EXPOSURE)?;

    // Ours first (they release into wgpu's device), then wgpu's objects.
    drop(profiler);
    drop(object);
    drop(ctx);
    let validation = host
        .validation
        .as_ref()
        .map(|v| v.take().iter().map(ToString::to_string).collect())
        .unwrap_or_default();
    let wgpu_errors = std::mem::take(&mut *wgpu_errors.lock().unwrap_or_else(|e| e.into_inner()));
    Ok(Outcome {
        validation,
        wgpu_errors,
        reports,
        solves,
        timings,
        image,
    })
}

#[allow(dead_code, reason = "the test includes this file for `run`")]
fn main() {
    let out = std::env::args_os().nth(1).map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../target/wgpu_host.png"),
        PathBuf::from,
    );
    let validation = std::env::var("TRANSLUCENT_VALIDATION").is_ok_and(|v| v == "1");
    match run(&out, validation) {
        Ok(o) if o.validation.is_empty() && o.wgpu_errors.is_empty() => {
            println!("wrote {}", out.display());
            for r in &o.reports {
                println!(
                    "frame {}: passes {:?}, skipped {:?}, warm start {}",
                    r.frame, r.passes, r.skipped, r.warm_start
                );
            }
            for s in &o.solves {
                println!("frame {} solve: iterations {:?}", s.frame, s.iterations());
            }
            for (frame, passes) in &o.timings {
                println!("frame {frame} GPU ms: {passes:?}");
            }
            println!(
                "the same frame from the command line:\n  {}",
                render_command()
            );
        }
        Ok(o) => {
            eprintln!(
                "{} validation message(s), {} wgpu error(s)",
                o.validation.len(),
                o.wgpu_errors.len()
            );
            std::process::exit(1);
        }
        Err(e) => {
            eprintln!("wgpu_host: {e}");
            std::process::exit(2);
        }
    }
}
