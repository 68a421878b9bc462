//! The render world: the scene extracted from the main world, our objects (created on the first
//! frame that draws them), and the render-graph node that records each object into every 3D
//! camera's main texture through `translucent::interop::wgpu`.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};

use bevy::ecs::query::QueryItem;
use bevy::prelude::*;
use bevy::render::render_graph::{NodeRunError, RenderGraphContext, RenderLabel, ViewNode};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue};
use bevy::render::view::{ExtractedView, ViewTarget};
use bevy::render::Extract;
use glam::DVec3;
use translucent::interop::wgpu::{vk_format, WgpuContext, WgpuTargets};
use translucent::scene::{Environment, Scene};
use translucent::vk::{FrameTimings, GpuProfiler};
use translucent::{FrameReport, TranslucentObject};

use crate::scene::{ambient, camera, Units, WorldLight};
use crate::{build_object, TranslucentError, TranslucentMesh};

/// The node's label in Bevy's `Core3d` graph (between the main transparent pass and the end of
/// the main pass).
#[derive(Debug, Hash, PartialEq, Eq, Clone, RenderLabel)]
pub struct TranslucentPass;

/// One object's frame, sent from the render world to the main world.
#[derive(Clone, Debug)]
pub struct ObjectFrame {
    /// The main-world entity with the [`TranslucentMesh`].
    pub entity: Entity,
    pub report: FrameReport,
    /// Our GPU timestamps of the object's last completed frame (`None` before one completed).
    pub gpu: Option<FrameTimings>,
}

/// What the render world sends back: frames and errors (drained by the main world each update).
#[derive(Default)]
pub struct Outbox {
    pub frames: Vec<ObjectFrame>,
    pub errors: Vec<String>,
}

/// The channel between the two worlds (one `Arc`, a resource in each).
#[derive(Resource, Clone, Default)]
pub struct Channel(pub Arc<Mutex<Outbox>>);

impl Channel {
    pub fn lock(&self) -> MutexGuard<'_, Outbox> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// The scene as extracted this frame (world space, mm).
#[derive(Resource, Default)]
pub struct Extracted {
    pub units: Units,
    pub objects: Vec<(Entity, TranslucentMesh, DVec3)>,
    pub lights: Vec<WorldLight>,
    pub environment: [f64; 3],
    pub errors: Vec<String>,
}

/// Copies the main world's objects, lights and ambient light into [`Extracted`].
#[allow(clippy::type_complexity)]
pub fn extract(
    mut out: ResMut<Extracted>,
    objects: Extract<Query<(Entity, &TranslucentMesh, &GlobalTransform)>>,
    directional: Extract<Query<(&DirectionalLight, &GlobalTransform)>>,
    points: Extract<Query<(&PointLight, &GlobalTransform)>>,
    spots: Extract<Query<(&SpotLight, &GlobalTransform)>>,
    ambient_light: Extract<Option<Res<GlobalAmbientLight>>>,
) {
    let units = out.units;
    out.objects = objects
        .iter()
        .map(|(e, m, at)| {
            (
                e,
                m.clone(),
                at.translation().as_dvec3() * units.mm_per_unit,
            )
        })
        .collect();
    let mut errors = Vec::new();
    let mut lights = Vec::new();
    for (l, at) in &directional {
        lights.push(WorldLight::directional(l.color, l.illuminance, at, &units));
    }
    for (l, at) in &points {
        lights.push(WorldLight::point(l.color, l.intensity, at, &units));
    }
    for (l, at) in &spots {
        lights.push(WorldLight::spot(
            l.color,
            l.intensity,
            l.inner_angle,
            l.outer_angle,
            at,
            &units,
        ));
    }
    out.lights = lights
        .into_iter()
        .filter_map(|l| l.map_err(|e| errors.push(e.to_string())).ok())
        .collect();
    out.environment = ambient_light
        .as_ref()
        .map(|a| ambient(a.color, a.brightness, &units))
        .unwrap_or([0.0; 3]);
    out.errors = errors;
}

/// One object of ours, with what it last drew.
struct Live {
    // Fields drop in order: the object and its profiler release into the context's device.
    object: TranslucentObject,
    profiler: GpuProfiler,
    source: TranslucentMesh,
    scene: Scene,
}

/// Our objects and the context borrowed from Bevy's wgpu device (dropped last).
struct Objects {
    live: HashMap<Entity, Live>,
    ctx: WgpuContext,
}

/// The render world's state: created on the first frame that draws (Bevy's device exists then).
#[derive(Resource, Default)]
pub struct RenderState {
    objects: Mutex<Option<Objects>>,
}

/// Frames the host may have recorded and not finished (per-frame profiler slots); the node waits
/// for wgpu when it is that far ahead.
pub const FRAMES_IN_FLIGHT: u32 = 2;

/// Records every translucent object into the view's main texture (after Bevy's main passes).
#[derive(Default)]
pub struct TranslucentNode;

impl ViewNode for TranslucentNode {
    type ViewQuery = (&'static ExtractedView, &'static ViewTarget);

    fn run<'w>(
        &self,
        _graph: &mut RenderGraphContext,
        render_context: &mut RenderContext<'w>,
        (view, target): QueryItem<'w, '_, Self::ViewQuery>,
        world: &'w World,
    ) -> Result<(), NodeRunError> {
        let channel = world.resource::<Channel>();
        let extracted = world.resource::<Extracted>();
        let state = world.resource::<RenderState>();
        let mut objects = state.objects.lock().unwrap_or_else(|e| e.into_inner());
        let buffers = draw(
            &mut objects,
            extracted,
            world.resource::<RenderDevice>(),
            world.resource::<RenderQueue>(),
            view,
            target,
        );
        let mut outbox = channel.lock();
        outbox.errors.extend(extracted.errors.iter().cloned());
        match buffers {
            Ok(frames) => {
                for (buffer, frame) in frames {
                    render_context.add_command_buffer(buffer);
                    outbox.frames.push(frame);
                }
            }
            Err(e) => outbox.errors.push(e.to_string()),
        }
        Ok(())
    }
}

/// Brings our objects in line with the extracted ones and records each for this view.
fn draw(
    objects: &mut Option<Objects>,
    extracted: &Extracted,
    device: &RenderDevice,
    queue: &RenderQueue,
    view: &ExtractedView,
    target: &ViewTarget,
) -> Result<Vec<(wgpu::CommandBuffer, ObjectFrame)>, TranslucentError> {
    if extracted.objects.is_empty() && objects.is_none() {
        return Ok(Vec::new());
    }
    let objects = match objects {
        Some(o) => o,
        None => {
            // SAFETY: Bevy submits to its queue only from its render system after the graph ran
            // (and we are inside the graph), so nothing else submits while our setup calls do.
            let ctx = unsafe { WgpuContext::new(device.wgpu_device(), queue, FRAMES_IN_FLIGHT)? };
            objects.insert(Objects {
                live: HashMap::new(),
                ctx,
            })
        }
    };
    let format = vk_format(target.main_texture_format())?;
    objects
        .live
        .retain(|e, _| extracted.objects.iter().any(|(o, _, _)| o == e));
    let mut out = Vec::new();
    for (entity, source, origin) in &extracted.objects {
        let scene = Scene {
            lights: extracted
                .lights
                .iter()
                .map(|l| l.in_object(*origin))
                .collect(),
            environment: Environment::Constant(extracted.environment),
        };
        let rebuild = objects.live.get(entity).is_none_or(|l| l.source != *source);
        if rebuild {
            objects.live.remove(entity);
            let object = build_object(&objects.ctx, source, &scene, format)?;
            let profiler = GpuProfiler::new(&objects.ctx, "bevy_translucent", 4096)?;
            objects.live.insert(
                *entity,
                Live {
                    object,
                    profiler,
                    source: source.clone(),
                    scene: scene.clone(),
                },
            );
        }
        let live = objects.live.get_mut(entity).expect("inserted above");
        if live.scene != scene {
            live.object.set_lights(&scene)?;
            live.scene = scene;
        }
        live.object.set_camera(Some(camera(
            &view.world_from_view,
            &view.clip_from_view,
            *origin,
            &extracted.units,
        )?))?;
        // Headless Bevy never waits for the GPU: keep at most FRAMES_IN_FLIGHT frames of ours
        // unfinished (the profiler's slots).
        let (recorded, completed) = objects.ctx.frames();
        if recorded >= completed + u64::from(FRAMES_IN_FLIGHT) {
            device
                .wgpu_device()
                .poll(wgpu::PollType::wait_indefinitely())
                .map_err(|e| TranslucentError::Wait(e.to_string()))?;
        }
        let (buffer, report) = objects.ctx.record_object(
            &mut live.object,
            &WgpuTargets {
                color: target.main_texture_view(),
                depth: None,
            },
            Some(&mut live.profiler),
        )?;
        let gpu = live.profiler.latest().cloned();
        out.push((
            buffer,
            ObjectFrame {
                entity: *entity,
                report,
                gpu,
            },
        ));
    }
    Ok(out)
}
