//! A headless Bevy app drawing a translucent torus (`bevy_translucent`) and reading it back:
//!
//! ```text
//! cargo run --release -p bevy_translucent --example bevy_scene [OUT.png]   # default target/bevy_scene.png
//! TRANSLUCENT_VALIDATION=1 cargo run --release -p bevy_translucent --example bevy_scene  # exits 1 on any message
//! ```
//!
//! Bevy renders to an `Image` (RGBA16F, `Hdr`, `Msaa::Off`, no tonemapping or dithering, cleared
//! to transparent black); the object is lit by a Bevy `DirectionalLight` and `GlobalAmbientLight`
//! and seen by a Bevy `Camera3d`. Frames: 1 the light turned by 40 degrees (a cold solve), 2 the
//! light back (a warm-started solve), 3 the camera moved (shading only), 4 the camera back (shading
//! only); frame 4 is read back with Bevy's `Readback`, written as PNG, and is the scene
//! `translucent render` draws with the command this program prints.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use bevy::camera::{ImageRenderTarget, RenderTarget};
use bevy::core_pipeline::tonemapping::{DebandDither, Tonemapping};
use bevy::diagnostic::DiagnosticsStore;
use bevy::ecs::system::RunSystemOnce as _;
use bevy::image::Image;
use bevy::prelude::*;
use bevy::render::gpu_readback::{Readback, ReadbackComplete};
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::render::view::Hdr;
use bevy::window::ExitCondition;
use bevy_translucent::{
    diagnostics, render_plugin, MeshSource, ObjectFrame, TranslucentFrames, TranslucentMesh,
    TranslucentPlugin,
};
use glam::DVec3;
use translucent::interop::wgpu::WgpuDesc;
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::quadgraph::BakeParams;
use translucent::scene::{Camera as OurCamera, Environment, Light, Scene};
use translucent::solver::gpu::GpuSolveParams;
use translucent::vk::{Context, LinearImage};
use translucent::{ObjectParams, QuadGraph, TranslucentObject};

pub const WIDTH: u32 = 160;
pub const HEIGHT: u32 = 120;
/// The object: `translucent render --shape torus --size-mm 30 --resolution 20 --levels 2`.
pub const SIZE_MM: f64 = 30.0;
pub const RESOLUTION: u32 = 20;
pub const LEVELS: u32 = 2;
pub const MATERIAL: &str = "marble";
/// The directional light's illuminance (our irradiance: `Units::light_scale` 1).
pub const ILLUMINANCE: f32 = 4.0;
/// The ambient light (our constant environment radiance).
pub const AMBIENT: [f32; 3] = [0.05, 0.05, 0.06];
pub const FOVY_DEG: f32 = 30.0;
/// Exposure of the written PNG.
pub const EXPOSURE: f32 = 1.5;
/// Updates waited for one rendered frame or the read-back before giving up.
const MAX_UPDATES: usize = 200;

/// The direction the light travels (turned: by 40 degrees about +Y).
pub fn light_direction(turned: bool) -> Vec3 {
    let d = Vec3::new(0.3, -0.8, -0.5).normalize();
    if turned {
        Quat::from_rotation_y(40f32.to_radians()) * d
    } else {
        d
    }
}

/// The camera's eye (moved: to the side); it looks at the origin.
pub fn eye(moved: bool) -> Vec3 {
    if moved {
        Vec3::new(25.0, 20.0, 55.0)
    } else {
        Vec3::new(0.0, 20.0, 60.0)
    }
}

pub fn torus() -> Shape {
    Shape::Torus {
        major: 0.35 * SIZE_MM,
        minor: 0.15 * SIZE_MM,
    }
}

/// The `translucent render` command of the compared frame.
pub fn render_command() -> String {
    let d = light_direction(false);
    let e = eye(false);
    let [r, g, b] = AMBIENT;
    format!(
        "translucent render --shape torus --size-mm {SIZE_MM} --resolution {RESOLUTION} --levels {LEVELS} \
         --material {MATERIAL} --light dir:{},{},{}:{ILLUMINANCE},{ILLUMINANCE},{ILLUMINANCE} \
         --env-constant {r},{g},{b} --camera {},{},{}:0,0,0:{FOVY_DEG} --width {WIDTH} --height {HEIGHT} \
         --schedule cascade --source flux --single-scattering off --bounce off \
         --supersample 1 --out reference.exr",
        d.x, d.y, d.z, e.x, e.y, e.z
    )
}

/// The scene of the compared frame (or the turned light) as our own scene.
pub fn our_scene(turned: bool) -> Scene {
    Scene {
        lights: vec![Light::Directional {
            direction: light_direction(turned).as_dvec3(),
            irradiance: [f64::from(ILLUMINANCE); 3],
        }],
        environment: Environment::Constant(AMBIENT.map(f64::from)),
    }
}

/// The Bevy camera as our own camera.
pub fn our_camera(moved: bool) -> OurCamera {
    OurCamera {
        eye: eye(moved).as_dvec3(),
        target: DVec3::ZERO,
        fovy_deg: f64::from(FOVY_DEG),
    }
}

/// The object as our own host draws it (`translucent render`'s bake and solve), in its default
/// colour and depth formats.
pub fn our_object(ctx: &Context, turned: bool) -> Result<TranslucentObject, translucent::Error> {
    let bake = BakeParams {
        resolution: RESOLUTION,
        levels: LEVELS,
        ..BakeParams::default()
    };
    let torus = torus();
    let graph = QuadGraph::bake(&torus.triangulate(96), &torus, &bake, &mut |_| {})?.0;
    let params = ObjectParams {
        solve: GpuSolveParams {
            iterations: vec![2000],
            tolerance: 1e-4,
            ..GpuSolveParams::default()
        },
        // The library's default is the real-time one (multigrid, second-collision source, single
        // scattering); this host pins the cascade, the boundary flux and no single scattering
        // that `render_command` names.
        single_scattering: None,
        ..ObjectParams::default()
    };
    let mut object = TranslucentObject::new(
        ctx,
        Arc::new(graph),
        &MaterialField::Homogeneous(Material::preset(MATERIAL)?),
        &our_scene(turned),
        &params,
    )?;
    object.set_camera(Some(our_camera(false)))?;
    Ok(object)
}

/// What one run produced.
pub struct Outcome {
    /// Khronos validation messages (with synchronization validation) of the whole app.
    pub validation: Vec<String>,
    /// The plugin's errors.
    pub errors: Vec<String>,
    /// The object frame that followed each change: cold, light back, camera moved, camera back.
    pub steps: Vec<ObjectFrame>,
    /// Every object frame the app drew (also the idle ones while waiting for the read-back).
    pub frames: Vec<ObjectFrame>,
    /// The diagnostics' history of `translucent/solve`, `warm_start`, `shading_only` (oldest first).
    pub diagnostics: Vec<(String, Vec<f64>)>,
    /// The read-back frame: linear radiance in Bevy's RGBA16F target.
    pub image: LinearImage,
}

#[derive(Resource, Clone, Default)]
struct Captured(Arc<Mutex<Option<Vec<u8>>>>);

#[derive(Component)]
struct TheCamera;

#[derive(Component)]
struct TheLight;

#[derive(Resource)]
struct Target(Handle<Image>);

fn setup(mut commands: Commands, mut images: ResMut<Assets<Image>>) {
    let mut image = Image::new_target_texture(WIDTH, HEIGHT, TextureFormat::Rgba16Float, None);
    image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
    let handle = images.add(image);
    commands.insert_resource(Target(handle.clone()));
    commands.spawn(TranslucentMesh {
        resolution: RESOLUTION,
        levels: LEVELS,
        ..TranslucentMesh::new(MeshSource::Shape(torus()), MATERIAL)
    });
    commands.spawn((
        TheLight,
        DirectionalLight {
            illuminance: ILLUMINANCE,
            color: Color::WHITE,
            ..default()
        },
        Transform::default().looking_to(light_direction(true), Vec3::Y),
    ));
    commands.insert_resource(GlobalAmbientLight {
        color: Color::linear_rgb(AMBIENT[0], AMBIENT[1], AMBIENT[2]),
        brightness: 1.0,
        ..default()
    });
    commands.spawn((
        TheCamera,
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::NONE),
            ..default()
        },
        RenderTarget::Image(ImageRenderTarget::from(handle)),
        Projection::Perspective(PerspectiveProjection {
            fov: FOVY_DEG.to_radians(),
            ..default()
        }),
        Hdr,
        Msaa::Off,
        Tonemapping::None,
        DebandDither::Disabled,
        Transform::from_translation(eye(false)).looking_at(Vec3::ZERO, Vec3::Y),
    ));
}

/// The headless app: Bevy's default plugins of our minimal feature set, on our device.
pub fn app(
    validation: bool,
) -> Result<(App, Option<translucent::interop::wgpu::ValidationMessages>), Box<dyn std::error::Error>>
{
    let (render, messages) = render_plugin(&WgpuDesc {
        validation,
        echo_validation: true,
        ..WgpuDesc::default()
    })?;
    let mut app = App::new();
    app.add_plugins((
        DefaultPlugins.set(render).set(WindowPlugin {
            primary_window: None,
            exit_condition: ExitCondition::DontExit,
            close_when_requested: false,
            ..default()
        }),
        TranslucentPlugin::default(),
    ))
    .init_resource::<Captured>()
    .add_systems(Startup, setup);
    app.finish();
    app.cleanup();
    Ok((app, messages))
}

/// Updates until the render world drew a new object frame (published at once); returns it.
pub fn step(app: &mut App, update_ms: &mut Vec<f64>) -> Result<ObjectFrame, String> {
    let before = app.world().resource::<TranslucentFrames>().frames.len();
    for _ in 0..MAX_UPDATES {
        let t = Instant::now();
        app.update();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        app.world_mut()
            .run_system_once(diagnostics::publish)
            .map_err(|e| e.to_string())?;
        let frames = app.world().resource::<TranslucentFrames>();
        if let Some(e) = frames.errors.first() {
            return Err(format!("bevy_translucent: {e}"));
        }
        if frames.frames.len() > before {
            update_ms.push(ms);
            return Ok(frames.frames[before].clone());
        }
    }
    Err(format!("no frame drawn in {MAX_UPDATES} updates"))
}

pub fn set_light(app: &mut App, turned: bool) {
    let world = app.world_mut();
    let mut q = world.query_filtered::<&mut Transform, With<TheLight>>();
    for mut t in q.iter_mut(world) {
        *t = Transform::default().looking_to(light_direction(turned), Vec3::Y);
    }
}

pub fn set_camera(app: &mut App, moved: bool) {
    let world = app.world_mut();
    let mut q = world.query_filtered::<&mut Transform, With<TheCamera>>();
    for mut t in q.iter_mut(world) {
        *t = Transform::from_translation(eye(moved)).looking_at(Vec3::ZERO, Vec3::Y);
    }
}

/// Runs the app: the 4 frames, then the read-back of the last; writes it to `out` as PNG.
pub fn run(out: &Path, validation: bool) -> Result<Outcome, Box<dyn std::error::Error>> {
    let (mut app, messages) = app(validation)?;
    let mut update_ms = Vec::new();
    let mut steps = vec![step(&mut app, &mut update_ms)?]; // frame 1: cold, light turned
    set_light(&mut app, false);
    steps.push(step(&mut app, &mut update_ms)?); // light back: warm
    set_camera(&mut app, true);
    steps.push(step(&mut app, &mut update_ms)?); // camera moved: shading only
    set_camera(&mut app, false);
    // The read-back of every frame from here on (all draw the same image).
    let target = app.world().resource::<Target>().0.clone();
    let captured = app.world().resource::<Captured>().clone();
    app.world_mut()
        .spawn(Readback::texture(target))
        .observe(move |ev: On<ReadbackComplete>| {
            let mut c = captured.0.lock().unwrap_or_else(|e| e.into_inner());
            c.get_or_insert_with(|| ev.data.clone());
        });
    steps.push(step(&mut app, &mut update_ms)?); // camera back: shading only
    let captured = app.world().resource::<Captured>().clone();
    let mut waited = 0;
    while captured
        .0
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .is_none()
    {
        if waited == MAX_UPDATES {
            return Err("the read-back never completed".into());
        }
        app.update();
        std::thread::sleep(Duration::from_millis(5));
        waited += 1;
    }
    let bytes = captured
        .0
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .take()
        .unwrap_or_default();
    let pixels: Vec<[f32; 4]> = bytemuck::cast_slice::<u8, [half::f16; 4]>(&bytes)
        .iter()
        .map(|p| p.map(f32::from))
        .collect();
    if pixels.len() != (WIDTH * HEIGHT) as usize {
        return Err(format!(
            "read back {} pixels, expected {}",
            pixels.len(),
            WIDTH * HEIGHT
        )
        .into());
    }
    let image = LinearImage {
        width: WIDTH,
        height: HEIGHT,
        pixels,
    };
    image.write_png(out, EXPOSURE)?;
    app.world_mut()
        .run_system_once(diagnostics::publish)
        .map_err(|e| e.to_string())?;
    let store = app.world().resource::<DiagnosticsStore>();
    let diagnostics = [
        diagnostics::SOLVE,
        diagnostics::WARM_START,
        diagnostics::SHADING_ONLY,
    ]
    .iter()
    .map(|p| {
        let values = store
            .get(p)
            .map(|d| d.values().copied().collect())
            .unwrap_or_default();
        (p.as_str().to_string(), values)
    })
    .collect();
    let frames = app.world_mut().resource_mut::<TranslucentFrames>();
    let (frames, errors) = (frames.frames.clone(), frames.errors.clone());
    // Bevy's render world (our objects, then our context) goes first, then the device.
    drop(app);
    let validation = messages
        .as_ref()
        .map(|v| v.take().iter().map(ToString::to_string).collect())
        .unwrap_or_default();
    Ok(Outcome {
        validation,
        errors,
        steps,
        frames,
        diagnostics,
        image,
    })
}

#[allow(dead_code)]
fn main() {
    let out = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("target/bevy_scene.png"));
    let validation = std::env::var("TRANSLUCENT_VALIDATION").is_ok_and(|v| v == "1");
    match run(&out, validation) {
        Ok(o) => {
            for (i, s) in o.steps.iter().enumerate() {
                println!(
                    "frame {}: passes {:?}, warm start {}, GPU ms of the last completed frame {:.2}",
                    i + 1,
                    s.report.passes,
                    s.report.warm_start,
                    s.gpu.as_ref().map(diagnostics::gpu_ms).unwrap_or(f64::NAN)
                );
            }
            println!("wrote {}", out.display());
            println!("the same scene: {}", render_command());
            if !o.errors.is_empty() || !o.validation.is_empty() {
                eprintln!("errors: {:?}\nvalidation: {:?}", o.errors, o.validation);
                std::process::exit(1);
            }
        }
        Err(e) => {
            eprintln!("bevy_scene: {e}");
            std::process::exit(1);
        }
    }
}
