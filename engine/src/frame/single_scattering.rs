//! [`SingleScatteringPass`]: single scattering (DESIGN 2.8) as a shared frame-graph pass between
//! the method's passes and the shading, so every method (quadgraph, voxel, dipole, a fixed
//! exitance) gets it. Per display vertex (as the f64 reference
//! [`crate::solver::single_scattering::vertex_single_scattering`], so the two compare vertex by
//! vertex), `single_scattering/march.comp` refracts the view ray, marches it at exponentially
//! stratified depths, reads each light's entry point (and its normal, from the depth's gradient)
//! from the shared shadow atlas and writes X = pi S per vertex into [`SingleScatteringPass::buffer`],
//! which the shading reads as a second vertex stream and adds to the method's exitance
//! (`F_t (J+ + X) / (pi eta^2)`, never below zero).
//!
//! Why per vertex and a pass of its own, not in the fragment shader: the march needs the whole
//! scene's lights and shadow views (a storage buffer the shading does not have), costs
//! O(vertices x samples x lights) whatever the resolution, shows as its own profiler scope, and
//! is the f64 reference's quantity, so a test compares them directly.
//!
//! Double counting: [`ScatterMode::Difference`] (the default) adds the march minus the flat-surface
//! closed form of each light lighting the vertex directly (the diffusion's source already carries
//! the flat part: zero on flat lit regions, all of the march in back-lit crescents), as the CPU's
//! `SingleScattering::Difference`. Material: one set of coefficients (the field's mean over the
//! display vertices for a heterogeneous field).
//!
//! ```no_run
//! # use translucent::frame::single_scattering::{ScatterParams, SingleScatteringPass};
//! # fn f(ctx: &translucent::vk::Context, mesh: &translucent::mesh::GpuMesh) -> Result<(), translucent::Error> {
//! let pass = SingleScatteringPass::new(ctx, mesh.vertex_count(), &ScatterParams::default())?;
//! assert_eq!(pass.buffer().size, 16 * mesh.vertex_count() as u64);
//! # Ok(()) }
//! ```

use ash::vk;
use glam::{DVec3, Vec3};

use crate::material::{Coefficients, MaterialField};
use crate::mesh::GpuMesh;
use crate::render::{GatherScene, RenderError, ShadowMaps};
use crate::scene::Scene;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::vk::barrier::Use;
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, MemoryUse, Sampler};
use crate::Error;

/// The pass's name (graph pass, debug label, profiler scope).
pub const PASS_SINGLE_SCATTERING: &str = "single_scattering";
/// Depths per view ray: DESIGN 2.8 asks for 4-16.
pub const SAMPLE_RANGE: std::ops::RangeInclusive<u32> = 4..=16;
/// The march starts this far below the vertex, relative to the object's bounding radius (as the
/// f64 reference's 1e-6 of its span, but above f32's resolution of a position).
const START_OFFSET: f64 = 1e-4;
/// The vertex's own visibility for the flat closed form: the gather's normal offset (texels).
const NORMAL_OFFSET_TEXELS: f32 = 1.5;

/// What the pass adds (see the module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ScatterMode {
    /// The march minus the flat-surface closed form of each directly lighting light.
    #[default]
    Difference,
    /// The march whole (for a diffusion source without the once-scattered light).
    Full,
}

/// How [`SingleScatteringPass`] marches.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScatterParams {
    /// Depths per view ray, in [`SAMPLE_RANGE`].
    pub samples: u32,
    pub mode: ScatterMode,
}

impl Default for ScatterParams {
    fn default() -> Self {
        ScatterParams {
            samples: 8,
            mode: ScatterMode::Difference,
        }
    }
}

/// Push constants of `single_scattering/march.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ScatterPush {
    /// xyz: the eye (object frame, mm).
    pub eye: [f32; 4],
    /// rgb: sigma_s' (1/mm); w: eta.
    pub sigma_s: [f32; 4],
    /// rgb: sigma_a (1/mm); w: the march's start below the vertex (mm).
    pub sigma_a: [f32; 4],
    pub vertex_count: u32,
    pub samples: u32,
    /// 1: difference to the flat closed form; 2: whole.
    pub mode: u32,
    pub normal_offset: f32,
    /// [`crate::render::SHADOW_SLOPE_BIAS`]: added back to the stored depths.
    pub depth_bias_slope: f32,
}

/// The march's pipeline, its output per vertex and its copy of the lights and shadow views.
pub struct SingleScatteringPass {
    pipeline: ComputePipeline<ScatterPush>,
    #[allow(dead_code, reason = "owned here: the descriptor set refers to it")]
    sampler: Sampler,
    scene: Buffer,
    output: Buffer,
    vertex_count: usize,
    set: Option<vk::DescriptorSet>,
    bound_vertices: vk::Buffer,
    params: ScatterParams,
    scene_data: Box<GatherScene>,
    coefficients: Coefficients,
    eta: f32,
    radius: f64,
}

fn invalid(what: &str, problem: String) -> Error {
    Error::Render(RenderError::Invalid {
        what: what.into(),
        problem,
    })
}

/// Descriptor sets one pass may allocate: one per display vertex buffer it meets (a voxel
/// object's new topologies); beyond this a typed error.
const MAX_SETS: u32 = 16;

impl SingleScatteringPass {
    /// The pass for a display mesh of `vertex_count` vertices; samples outside [`SAMPLE_RANGE`]
    /// are a typed error. The output starts at zero (what the shading adds when the pass is off).
    pub fn new(
        ctx: &Context,
        vertex_count: usize,
        params: &ScatterParams,
    ) -> Result<SingleScatteringPass, Error> {
        if !SAMPLE_RANGE.contains(&params.samples) {
            return Err(invalid(
                "single-scattering samples",
                format!(
                    "{} depths per ray; DESIGN 2.8 takes {}..={}",
                    params.samples,
                    SAMPLE_RANGE.start(),
                    SAMPLE_RANGE.end()
                ),
            ));
        }
        let pipeline = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "single scattering",
                shader: "single_scattering/march.comp",
                bindings: &["vertices", "scattered", "shadow_atlas", "scene"],
                max_sets: MAX_SETS,
            },
        )?;
        // texelFetch of raw depths (no compare), as the gather's.
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(vk::Filter::NEAREST)
            .min_filter(vk::Filter::NEAREST)
            .address_mode_u(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_v(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .address_mode_w(vk::SamplerAddressMode::CLAMP_TO_EDGE)
            .max_lod(0.0);
        let sampler = Sampler::new(ctx, "single scattering atlas sampler", &info)?;
        let scene = Buffer::new(
            ctx,
            &BufferDesc {
                name: "single scattering scene",
                size: std::mem::size_of::<GatherScene>() as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::GpuOnly,
            },
        )?;
        Ok(SingleScatteringPass {
            pipeline,
            sampler,
            scene,
            output: Self::zeroed_output(ctx, vertex_count)?,
            vertex_count,
            set: None,
            bound_vertices: vk::Buffer::null(),
            params: *params,
            scene_data: Box::new(bytemuck::Zeroable::zeroed()),
            coefficients: Coefficients {
                sigma_s: [0.0; 3],
                sigma_a: [0.0; 3],
            },
            eta: 1.0,
            radius: 1.0,
        })
    }

    fn zeroed_output(ctx: &Context, vertex_count: usize) -> Result<Buffer, Error> {
        Ok(Buffer::with_data(
            ctx,
            "single scattering per vertex",
            // VERTEX: the shading reads it as a second vertex stream; STORAGE: the march writes it.
            // TRANSFER_SRC: read back for checks.
            vk::BufferUsageFlags::VERTEX_BUFFER
                | vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC,
            &vec![[0.0f32; 4]; vertex_count.max(1)],
        )?)
    }

    /// X per vertex (rgb, w unused): the shading's second vertex stream.
    pub fn buffer(&self) -> &Buffer {
        &self.output
    }

    /// Reads X per vertex back (waits for the GPU): for tests and tools, after a frame completed.
    pub fn read(&self, ctx: &Context) -> Result<Vec<[f32; 3]>, Error> {
        let copy = Buffer::new(
            ctx,
            &BufferDesc {
                name: "single scattering read-back",
                size: self.output.size,
                usage: vk::BufferUsageFlags::TRANSFER_DST,
                memory: MemoryUse::Readback,
            },
        )?;
        ctx.execute("single scattering read-back", |cb| {
            // SAFETY: `cb` is recording; both buffers outlive the waited submission.
            unsafe {
                // why: the shading (or the march) of a finished frame used it; order the copy after.
                barrier::memory(ctx, cb, Access::VertexInput, Access::TransferSrc);
                barrier::memory(ctx, cb, Access::ComputeWrite, Access::TransferSrc);
                let region = [vk::BufferCopy {
                    src_offset: 0,
                    dst_offset: 0,
                    size: self.output.size,
                }];
                ctx.raw()
                    .cmd_copy_buffer(cb, self.output.raw, copy.raw, &region);
                // why: the CPU maps and reads the copy after the wait (RAW through the host).
                barrier::memory(ctx, cb, Access::TransferDst, Access::HostRead);
            }
            Ok(())
        })?;
        let values: &[[f32; 4]] = bytemuck::cast_slice(copy.read_bytes()?);
        Ok(values
            .iter()
            .take(self.vertex_count)
            .map(|v| [v[0], v[1], v[2]])
            .collect())
    }

    /// The march's parameters.
    pub fn params(&self) -> ScatterParams {
        self.params
    }

    /// A display mesh of a new vertex count (a voxel object's new topology): a zeroed output.
    pub fn resize(&mut self, ctx: &Context, vertex_count: usize) -> Result<(), Error> {
        if vertex_count != self.vertex_count {
            self.output = Self::zeroed_output(ctx, vertex_count)?;
            self.vertex_count = vertex_count;
            self.set = None;
        }
        Ok(())
    }

    /// The lights and shadow views (`shadows` fitted to `scene`'s lights), the object's bounding
    /// radius (mm; sets the march's start offset).
    pub fn set_lights(
        &mut self,
        scene: &Scene,
        shadows: &ShadowMaps,
        radius: f64,
    ) -> Result<(), Error> {
        *self.scene_data = GatherScene::new(scene, shadows)?;
        self.radius = radius;
        Ok(())
    }

    /// The material: `field`'s coefficients (homogeneous), or their mean over `positions` (the
    /// display vertices) for a heterogeneous field.
    pub fn set_material(&mut self, field: &MaterialField, positions: &[DVec3]) {
        self.eta = field.eta() as f32;
        self.coefficients = match field {
            MaterialField::Homogeneous(m) => m.coefficients(),
            _ => {
                let mut sum = Coefficients {
                    sigma_s: [0.0; 3],
                    sigma_a: [0.0; 3],
                };
                for p in positions {
                    let c = field.sample(*p);
                    for ch in 0..3 {
                        sum.sigma_s[ch] += c.sigma_s[ch] / positions.len().max(1) as f64;
                        sum.sigma_a[ch] += c.sigma_a[ch] / positions.len().max(1) as f64;
                    }
                }
                sum
            }
        };
    }

    /// What [`Self::record`] uses: the display mesh's vertices (positions, normals), the shadow
    /// atlas, its own output (written).
    pub fn uses<'a>(&'a self, mesh: &'a GpuMesh, shadows: &'a ShadowMaps) -> [Use<'a>; 3] {
        [
            Use::buffer(mesh.vertex_buffer(), Access::ComputeRead),
            Use::image(&shadows.atlas, Access::DepthSampledShaders),
            Use::buffer(&self.output, Access::ComputeWrite),
        ]
    }

    /// Binds `mesh` and `shadows` (a new descriptor set when the vertex buffer changed).
    pub fn bind(
        &mut self,
        ctx: &Context,
        mesh: &GpuMesh,
        shadows: &ShadowMaps,
    ) -> Result<(), Error> {
        if mesh.vertex_count() != self.vertex_count {
            return Err(invalid(
                "single scattering",
                format!(
                    "sized for {} vertices, the mesh has {}: call resize",
                    self.vertex_count,
                    mesh.vertex_count()
                ),
            ));
        }
        if self.set.is_none() || self.bound_vertices != mesh.vertex_buffer().raw {
            self.set = Some(self.pipeline.allocate_set(
                ctx,
                &[
                    DescriptorWrite::StorageBuffer {
                        name: "vertices",
                        buffer: mesh.vertex_buffer(),
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "scattered",
                        buffer: &self.output,
                    },
                    DescriptorWrite::SampledImage {
                        name: "shadow_atlas",
                        image: &shadows.atlas,
                        sampler: self.sampler.raw,
                        layout: vk::ImageLayout::DEPTH_READ_ONLY_OPTIMAL,
                    },
                    DescriptorWrite::StorageBuffer {
                        name: "scene",
                        buffer: &self.scene,
                    },
                ],
            )?);
            self.bound_vertices = mesh.vertex_buffer().raw;
        }
        Ok(())
    }

    /// Records the march for the eye at `eye` (object frame, mm).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, inside a frame-graph pass declaring
    /// [`Self::uses`], after [`Self::bind`] with the same mesh and shadows; all of it must
    /// outlive the execution.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        eye: Vec3,
    ) -> Result<(), Error> {
        let Some(set) = self.set else {
            return Err(invalid("single scattering", "recorded before bind".into()));
        };
        let c = self.coefficients;
        let f = |v: [f64; 3], w: f32| [v[0] as f32, v[1] as f32, v[2] as f32, w];
        let push = ScatterPush {
            eye: eye.extend(1.0).to_array(),
            sigma_s: f(c.sigma_s, self.eta),
            sigma_a: f(c.sigma_a, (START_OFFSET * self.radius) as f32),
            vertex_count: self.vertex_count as u32,
            samples: self.params.samples,
            mode: match self.params.mode {
                ScatterMode::Difference => 1,
                ScatterMode::Full => 2,
            },
            normal_offset: NORMAL_OFFSET_TEXELS,
            depth_bias_slope: crate::render::SHADOW_SLOPE_BIAS,
        };
        // SAFETY: the caller's contract; the scene buffer is under vkCmdUpdateBuffer's 65536 bytes.
        unsafe {
            // why: the last frame's march read the scene buffer before this update (WAR).
            barrier::memory(ctx, cb, Access::ComputeRead, Access::TransferDst);
            ctx.raw().cmd_update_buffer(
                cb,
                self.scene.raw,
                0,
                bytemuck::bytes_of(&*self.scene_data),
            );
            // why: the march reads the scene just written (RAW).
            barrier::memory(ctx, cb, Access::TransferDst, Access::ComputeRead);
            self.pipeline
                .dispatch(ctx, cb, set, &push, [self.vertex_count as u32, 1, 1]);
        }
        Ok(())
    }
}
