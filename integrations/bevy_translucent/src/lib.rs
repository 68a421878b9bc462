//! A Bevy 0.18 plugin drawing translucent objects (subsurface scattering by our frame graph) into
//! Bevy's 3D cameras, through `translucent::interop::wgpu` on Bevy's own wgpu 27 Vulkan device.
//!
//! - **Device.** wgpu does not enable the Vulkan 1.3 features we record with, so the device is
//!   opened by us and handed to Bevy: [`render_plugin`] returns the `RenderPlugin` (Bevy's
//!   `RenderCreation::Manual`) to put in place of the default one.
//! - **Scene.** An entity with a [`TranslucentMesh`] (mesh or shape, material preset, bake
//!   resolution) and a `Transform` is an object (translation only: see [`scene`]); Bevy's
//!   `DirectionalLight`, `PointLight`, `SpotLight` and `GlobalAmbientLight` light it, each 3D
//!   camera (perspective, `Msaa::Off`) views it. Lengths and light units: [`scene::Units`].
//! - **Drawing.** A render-graph node ([`render::TranslucentPass`], in `Core3d` after the main
//!   transparent pass) records each object into the view's main texture in a command buffer of its
//!   own (`WgpuContext::record_object`), queued in Bevy's order. Our depth buffer is the object's
//!   own (Bevy's reverse-z depth is not compared against).
//! - **Reports.** Each frame's [`translucent::FrameReport`] reaches the main world as
//!   [`TranslucentFrames`] and as Bevy diagnostics ([`diagnostics`]): passes, skips, solves,
//!   warm starts and our GPU ms.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy_translucent::{render_plugin, MeshSource, TranslucentMesh, TranslucentPlugin};
//! use translucent::interop::wgpu::WgpuDesc;
//! use translucent::mesh::shapes::Shape;
//!
//! let (render, _validation) = render_plugin(&WgpuDesc::default()).expect("a Vulkan 1.3 device");
//! App::new()
//!     .add_plugins((DefaultPlugins.set(render), TranslucentPlugin::default()))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn(TranslucentMesh::new(
//!             MeshSource::Shape(Shape::Torus { major: 10.5, minor: 4.5 }),
//!             "marble",
//!         ));
//!         commands.spawn((
//!             DirectionalLight { illuminance: 4.0, ..default() },
//!             Transform::default().looking_to(Vec3::new(0.3, -0.8, -0.5), Vec3::Y),
//!         ));
//!         commands.spawn((
//!             Camera3d::default(),
//!             Msaa::Off,
//!             Transform::from_xyz(0.0, 20.0, 60.0).looking_at(Vec3::ZERO, Vec3::Y),
//!         ));
//!     })
//!     .run();
//! ```

pub mod diagnostics;
pub mod render;
pub mod scene;

use std::path::PathBuf;

use bevy::app::{App, Plugin, Update};
use bevy::core_pipeline::core_3d::graph::{Core3d, Node3d};
use bevy::diagnostic::RegisterDiagnostic as _;
use bevy::ecs::component::Component;
use bevy::render::render_graph::{RenderGraphExt as _, ViewNodeRunner};
use bevy::render::renderer::{
    RenderAdapter, RenderAdapterInfo, RenderDevice, RenderInstance, RenderQueue, WgpuWrapper,
};
use bevy::render::settings::{RenderCreation, RenderResources};
use bevy::render::{ExtractSchedule, RenderApp, RenderPlugin};
use bevy::transform::components::Transform;
use std::sync::Arc;
use translucent::interop::wgpu::{create_device, ValidationMessages, WgpuDesc, WgpuError};
use translucent::material::{Material, MaterialField};
use translucent::mesh::shapes::Shape;
use translucent::mesh::{MeshSolid, ValidateOptions};
use translucent::quadgraph::BakeParams;
use translucent::scene::Scene;
use translucent::solver::gpu::GpuSolveParams;
use translucent::{ObjectParams, QuadGraph, TranslucentObject};

pub use diagnostics::TranslucentFrames;
pub use render::ObjectFrame;
pub use scene::Units;

/// Everything the plugin can fail with (reported in [`TranslucentFrames::errors`]).
#[derive(Debug, thiserror::Error)]
pub enum TranslucentError {
    #[error(transparent)]
    Wgpu(#[from] WgpuError),
    #[error(transparent)]
    Translucent(#[from] translucent::Error),
    #[error(transparent)]
    Vk(#[from] translucent::vk::VkError),
    #[error(transparent)]
    Scene(#[from] scene::SceneError),
    #[error("material {name:?}: {source}")]
    Material {
        name: String,
        source: translucent::material::MaterialError,
    },
    #[error("mesh {path:?}: {source}")]
    Mesh {
        path: PathBuf,
        source: translucent::mesh::MeshError,
    },
    #[error("baking the QuadGraph: {0}")]
    Bake(#[from] translucent::quadgraph::BakeError),
    #[error("waiting for wgpu: {0}")]
    Wait(String),
}

/// Where an object's surface comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshSource {
    /// A procedural shape (mm), triangulated as `translucent render --shape` does.
    Shape(Shape),
    /// A Wavefront OBJ scaled to `size_mm` (its bounding box's longest side), as `--mesh`.
    Obj { path: PathBuf, size_mm: f64 },
}

/// A translucent object: its mesh, material preset (`materials.csv`, e.g. "marble") and the
/// QuadGraph's bake (`translucent render --resolution --levels`). Changing it rebuilds the object.
#[derive(Component, Clone, Debug, PartialEq)]
#[require(Transform)]
pub struct TranslucentMesh {
    pub source: MeshSource,
    pub material: String,
    pub resolution: u32,
    pub levels: u32,
    /// The solve's stopping tolerance (`translucent render`'s default 1e-4).
    pub tolerance: f32,
}

impl TranslucentMesh {
    /// A mesh and material with `translucent render`'s bake (resolution 20, 2 levels).
    pub fn new(source: MeshSource, material: &str) -> Self {
        TranslucentMesh {
            source,
            material: material.to_string(),
            resolution: 20,
            levels: 2,
            tolerance: 1e-4,
        }
    }
}

/// Triangles per procedural shape (`translucent render --shape`'s).
const SHAPE_TRIANGULATION: u32 = 96;

/// Bakes `source` and creates its object for a colour target of `format` (our own depth).
pub(crate) fn build_object(
    ctx: &translucent::vk::Context,
    source: &TranslucentMesh,
    scene: &Scene,
    format: ash::vk::Format,
) -> Result<TranslucentObject, TranslucentError> {
    let material = Material::preset(&source.material).map_err(|e| TranslucentError::Material {
        name: source.material.clone(),
        source: e,
    })?;
    let bake = BakeParams {
        resolution: source.resolution,
        levels: source.levels,
        ..BakeParams::default()
    };
    let graph = match &source.source {
        MeshSource::Shape(shape) => {
            QuadGraph::bake(
                &shape.triangulate(SHAPE_TRIANGULATION),
                shape,
                &bake,
                &mut |_| {},
            )?
            .0
        }
        MeshSource::Obj { path, size_mm } => {
            let (solid, _, _) = MeshSolid::load(path, *size_mm, &ValidateOptions::default())
                .map_err(|e| TranslucentError::Mesh {
                    path: path.clone(),
                    source: e,
                })?;
            QuadGraph::bake(solid.mesh(), &solid, &bake, &mut |_| {})?.0
        }
    };
    let params = ObjectParams {
        solve: GpuSolveParams {
            iterations: vec![2000],
            tolerance: source.tolerance,
            ..GpuSolveParams::default()
        },
        color_format: format,
        // The library's default is the real-time one; the plugin keeps the solve above (cascade,
        // boundary flux) and no single scattering, as its example's render command names.
        single_scattering: None,
        ..ObjectParams::default()
    };
    Ok(TranslucentObject::new(
        ctx,
        Arc::new(graph),
        &MaterialField::Homogeneous(material),
        scene,
        &params,
    )?)
}

/// Opens a wgpu device with the Vulkan 1.3 features we record with (`create_device`: adapter by
/// `desc.device_name`, validation by `desc.validation`) and returns Bevy's `RenderPlugin` on it,
/// with the validation messages (`Some` with validation).
pub fn render_plugin(
    desc: &WgpuDesc,
) -> Result<(RenderPlugin, Option<ValidationMessages>), WgpuError> {
    let host = create_device(desc)?;
    let info = host.adapter.get_info();
    let resources = RenderResources(
        RenderDevice::from(host.device),
        RenderQueue(Arc::new(WgpuWrapper::new(host.queue))),
        RenderAdapterInfo(WgpuWrapper::new(info)),
        RenderAdapter(Arc::new(WgpuWrapper::new(host.adapter))),
        RenderInstance(Arc::new(WgpuWrapper::new(host.instance))),
    );
    Ok((
        RenderPlugin {
            render_creation: RenderCreation::Manual(resources),
            ..Default::default()
        },
        host.validation,
    ))
}

/// Adds the extraction, the render-graph node, [`TranslucentFrames`] and the diagnostics.
#[derive(Clone, Copy, Debug, Default)]
pub struct TranslucentPlugin {
    pub units: Units,
}

impl Plugin for TranslucentPlugin {
    fn build(&self, app: &mut App) {
        let channel = render::Channel::default();
        app.insert_resource(channel.clone())
            .init_resource::<TranslucentFrames>()
            .add_systems(Update, diagnostics::publish);
        for path in diagnostics::PATHS {
            app.register_diagnostic(bevy::diagnostic::Diagnostic::new(path.clone()));
        }
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .insert_resource(channel)
            .insert_resource(render::Extracted {
                units: self.units,
                ..Default::default()
            })
            .init_resource::<render::RenderState>()
            .add_systems(ExtractSchedule, render::extract)
            .add_render_graph_node::<ViewNodeRunner<render::TranslucentNode>>(
                Core3d,
                render::TranslucentPass,
            )
            .add_render_graph_edges(
                Core3d,
                (
                    Node3d::MainTransparentPass,
                    render::TranslucentPass,
                    Node3d::EndMainPass,
                ),
            );
    }
}
