//! [`InjectPass`]: light into the surface voxels (paper section 2.1, Eqs. 2-3): every solid voxel
//! next to an empty one gathers the reflective-shadow-map texels whose surface points lie within
//! [`KERNEL_REACH_VOXELS`] of its centre (a smooth kernel of the distance) and starts at
//! n0 = -ln(q), q the irradiance transmitted into the surface there, per colour channel
//! (`voxel/inject_light.comp` explains the kernel and the area normalization). It also
//! initialises the relaxation's state (`state[0]` = n0) and path lengths (0).

use ash::vk;

use super::rsm::ReflectiveShadowMaps;
use crate::material::fresnel;
use crate::scene::Environment;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite};
use crate::solver::voxel::sync::ResourceUse;
use crate::solver::voxel::VoxelGrid;
use crate::vk::{Access, Context, GpuProfiler, Sampler};
use crate::Error;

/// Profiler scope and debug label of the pass.
pub const PASS_INJECT: &str = "voxel inject";
/// The injection kernel's radius, in voxels: more than the surface shell's depth (a shell voxel's
/// centre lies up to sqrt 3 voxels deep on a tilted surface), so each of its voxels sees the
/// surface near it. Every shell voxel gets the local transmitted irradiance; with one owner voxel
/// per texel (before) the deeper shell voxels of tilted surfaces started unlit: the mottling.
pub const KERNEL_REACH_VOXELS: f32 = 2.0;

/// Push constants of `voxel/inject_light.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct InjectPush {
    pub dims: [u32; 4],
    /// rgb: a constant environment's transmitted irradiance pi L (1 - F_dr,ext).
    pub env_q: [f32; 4],
    pub view_count: u32,
    /// The kernel's radius in voxels ([`KERNEL_REACH_VOXELS`]).
    pub reach: f32,
    pub track_path: u32,
    pub pad: u32,
}

/// The injection pass.
pub struct InjectPass {
    pipeline: ComputePipeline<InjectPush>,
    set: vk::DescriptorSet,
    #[allow(dead_code, reason = "owned here: the descriptor set refers to it")]
    sampler: Sampler,
    env_q: [f32; 3],
}

impl InjectPass {
    pub fn new(
        ctx: &Context,
        grid: &VoxelGrid,
        rsm: &ReflectiveShadowMaps,
    ) -> Result<InjectPass, Error> {
        let pipeline = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "voxel inject",
                shader: "voxel/inject_light.comp",
                bindings: &[
                    "grid",
                    "medium",
                    "rsm_position",
                    "rsm_normal",
                    "rsm_irradiance",
                    "rsm",
                    "seed",
                    "state",
                    "path",
                ],
                max_sets: 1,
            },
        )?;
        // texelFetch only: the filter never applies.
        let sampler = Sampler::new(
            ctx,
            "rsm texel fetch",
            &vk::SamplerCreateInfo::default()
                .mag_filter(vk::Filter::NEAREST)
                .min_filter(vk::Filter::NEAREST)
                .max_lod(0.0),
        )?;
        let map = |name, image| DescriptorWrite::SampledImage {
            name,
            image,
            sampler: sampler.raw,
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        };
        let set = pipeline.allocate_set(
            ctx,
            &[
                DescriptorWrite::StorageBuffer {
                    name: "grid",
                    buffer: &grid.frame,
                },
                DescriptorWrite::storage_image("medium", &grid.medium),
                map("rsm_position", &rsm.position),
                map("rsm_normal", &rsm.normal),
                map("rsm_irradiance", &rsm.irradiance),
                DescriptorWrite::StorageBuffer {
                    name: "rsm",
                    buffer: &rsm.views_buffer,
                },
                DescriptorWrite::storage_image("seed", &grid.seed),
                DescriptorWrite::storage_image("state", &grid.state[0]),
                DescriptorWrite::storage_image("path", &grid.path[0]),
            ],
        )?;
        Ok(InjectPass {
            pipeline,
            set,
            sampler,
            env_q: [0.0; 3],
        })
    }

    /// A constant environment of radiance L adds q = pi L (1 - F_dr,ext) at every surface voxel
    /// (unshadowed, as the QuadGraph's gather). An SH environment is not supported here yet (a
    /// typed error; phase 2 shares the gather's SH irradiance).
    pub fn set_environment(&mut self, environment: &Environment, eta: f64) -> Result<(), Error> {
        environment.validate()?;
        self.env_q = match environment {
            Environment::None => [0.0; 3],
            Environment::Constant(l) => {
                let t = std::f64::consts::PI * (1.0 - fresnel::external_diffuse_reflectance(eta));
                [(l[0] * t) as f32, (l[1] * t) as f32, (l[2] * t) as f32]
            }
            Environment::SphericalHarmonics(_) => {
                return Err(crate::solver::voxel::bad_param(
                    "environment",
                    "the voxel method injects a constant environment only (SH: phase 2)",
                )
                .into())
            }
        };
        Ok(())
    }

    /// Reads: the grid frame and medium, the reflective shadow maps (sampled) and their views.
    /// Writes: the seed, the first state and path images.
    pub fn declare<'a>(
        &self,
        grid: &'a VoxelGrid,
        rsm: &'a ReflectiveShadowMaps,
    ) -> Vec<ResourceUse<'a>> {
        vec![
            ResourceUse::buffer(&grid.frame, Access::ComputeRead),
            ResourceUse::image(&grid.medium, Access::ComputeRead),
            ResourceUse::image(&rsm.position, Access::ShadersSampled),
            ResourceUse::image(&rsm.normal, Access::ShadersSampled),
            ResourceUse::image(&rsm.irradiance, Access::ShadersSampled),
            ResourceUse::buffer(&rsm.views_buffer, Access::ComputeRead),
            ResourceUse::image(&grid.seed, Access::ComputeWrite),
            ResourceUse::image(&grid.state[0], Access::ComputeWrite),
            // Bound either way (a placeholder without paths): GENERAL.
            ResourceUse::image(&grid.path[0], Access::ComputeWrite),
        ]
    }

    /// Records the injection (one dispatch over the grid).
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, the declared resources in their declared
    /// states and alive until it completes.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        grid: &VoxelGrid,
        rsm: &ReflectiveShadowMaps,
        profiler: Option<&mut GpuProfiler>,
    ) {
        let dims = grid.dims.push();
        let mut profiler = profiler;
        // SAFETY: the caller's contract.
        unsafe {
            ctx.begin_label(cb, PASS_INJECT);
            if let Some(p) = profiler.as_deref_mut() {
                p.begin_scope(cb, PASS_INJECT);
            }
            self.pipeline.dispatch(
                ctx,
                cb,
                self.set,
                &InjectPush {
                    dims,
                    env_q: [self.env_q[0], self.env_q[1], self.env_q[2], 0.0],
                    view_count: rsm.views().len() as u32,
                    reach: KERNEL_REACH_VOXELS,
                    track_path: u32::from(grid.track_path),
                    pad: 0,
                },
                [dims[0], dims[1], dims[2]],
            );
            if let Some(p) = profiler {
                p.end_scope(cb);
            }
            ctx.end_label(cb);
        }
    }
}
