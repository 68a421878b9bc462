//! [`RelaxPass`]: the shortest optical path from the lit surface voxels to every voxel (paper
//! section 2.1: Dijkstra's algorithm on the voxel graph, "weighted goal nodes"), per colour
//! channel, over the 26-neighbourhood, edge cost c_uv = (sigma_u + sigma_v) / 2 * |x_u - x_v|.
//!
//! Dijkstra is sequential; on the GPU the same fixed point comes from min-plus relaxation:
//! - [`Relaxation::Jacobi`] (`voxel/relax_step.comp`): every voxel, every iteration, ping-pong
//!   (Bellman-Ford); after k iterations it has the best paths of at most k edges. Blocks of
//!   [`VoxelParams::block`] iterations, then `voxel/relax_control.comp` zeroes the indirect
//!   dispatch arguments of the remaining blocks once the last iteration of a block changed
//!   nothing: the exact fixed point. No CPU read-back inside a frame; [`RelaxPass::control`]
//!   reads the iterations afterwards.
//! - [`Relaxation::Sweep`] (`voxel/relax_sweep.comp`): slice after slice along +-x, +-y, +-z,
//!   in place (fast sweeping): a sweep carries a path across the whole grid; rounds of six
//!   sweeps until a round changes nothing.
//!
//! Both are exact: every value is a real path's cost, summed in the order the CPU reference sums
//! it ([`super::cpu::dijkstra`]), and the fixed point of the min-plus equations is the minimum
//! over all paths, which Dijkstra's algorithm finds too (f32 addition is monotone, so Dijkstra's
//! greedy order stays valid). Ties do not matter for n: equal costs are equal values, whichever
//! path gave them. With [`VoxelParams::soft_beta`] > 0 the minimum becomes a soft minimum (Jacobi
//! only), and "nothing changed" means no change above [`VoxelParams::soft_tolerance`].
//!
//! [`VoxelParams::block`]: super::VoxelParams::block
//! [`VoxelParams::soft_beta`]: super::VoxelParams::soft_beta
//! [`VoxelParams::soft_tolerance`]: super::VoxelParams::soft_tolerance

use ash::vk;

use super::grid::{host_sync, VoxelGrid};
use super::sync::ResourceUse;
use super::{Relaxation, VoxelParams};
use crate::material::fresnel;
use crate::shader::{ComputePipeline, ComputePipelineDesc, DescriptorWrite, SpecConstant};
use crate::vk::{barrier, Access, Buffer, BufferDesc, Context, GpuProfiler, MemoryUse};
use crate::Error;

/// Profiler scope and debug label of the pass.
pub const PASS_RELAX: &str = "voxel relax";
/// Sweeps in a round: +-x, +-y, +-z.
pub const SWEEPS_PER_ROUND: u32 = 6;
/// Rounds a frame records by default with [`Relaxation::Sweep`].
pub const DEFAULT_SWEEP_ROUNDS: u32 = 16;

/// The control record (`voxel/relax_common.glsl`, std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RelaxControl {
    /// VkDispatchIndirectCommand of the Jacobi iterations.
    pub groups: [u32; 3],
    /// Iterations (Jacobi) or sweeps run.
    pub iterations: u32,
    /// Control decisions taken while running.
    pub blocks: u32,
    /// Workgroups that changed a value since the last decision.
    pub changed: u32,
    /// 1 once a block (round) changed nothing.
    pub converged: u32,
    pub pad: u32,
    /// VkDispatchIndirectCommand of a sweep slice along x, y, z (w unused).
    pub sweep: [[u32; 4]; 3],
}

/// Push constants of `voxel/relax_step.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct RelaxPush {
    pub dims: [u32; 4],
    pub beta: f32,
    pub tolerance: f32,
    pub flag_changes: u32,
    /// A = (1 + F_dr) / (1 - F_dr) (the diffusion model's profile).
    pub big_a: f32,
}

/// Push constants of `voxel/relax_sweep.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct SweepPush {
    pub dims: [u32; 4],
    pub axis: u32,
    pub step: i32,
    pub slice: u32,
    pub pad: u32,
}

/// Push constants of `voxel/relax_control.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ControlPush {
    pub k: u32,
    pub pad: [u32; 3],
}

fn raw_barrier(
    src_stage: vk::PipelineStageFlags2,
    src_access: vk::AccessFlags2,
    dst_stage: vk::PipelineStageFlags2,
    dst_access: vk::AccessFlags2,
) -> vk::MemoryBarrier2<'static> {
    vk::MemoryBarrier2::default()
        .src_stage_mask(src_stage)
        .src_access_mask(src_access)
        .dst_stage_mask(dst_stage)
        .dst_access_mask(dst_access)
}

/// The relaxation pass (see the module doc).
pub struct RelaxPass {
    jacobi: Option<(ComputePipeline<RelaxPush>, [vk::DescriptorSet; 2])>,
    sweep: Option<(ComputePipeline<SweepPush>, vk::DescriptorSet)>,
    decide: ComputePipeline<ControlPush>,
    decide_set: vk::DescriptorSet,
    /// The control record; host-visible, read after the frame ([`Self::control`]).
    pub control: Buffer,
    relaxation: Relaxation,
    beta: f32,
    tolerance: f32,
    /// Iterations (or sweeps) per control decision.
    k: u32,
    /// Blocks (rounds) recorded per frame.
    blocks: u32,
    initial: RelaxControl,
    big_a: f32,
}

impl RelaxPass {
    pub fn new(
        ctx: &Context,
        grid: &VoxelGrid,
        params: &VoxelParams,
        eta: f64,
    ) -> Result<RelaxPass, Error> {
        params.validate()?;
        let d = grid.dims.dims;
        let control = Buffer::new(
            ctx,
            &BufferDesc {
                name: "voxel relax control",
                size: std::mem::size_of::<RelaxControl>() as u64,
                usage: vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                memory: MemoryUse::Readback,
            },
        )?;
        let control_write = DescriptorWrite::StorageBuffer {
            name: "control",
            buffer: &control,
        };
        let decide = ComputePipeline::new(
            ctx,
            &ComputePipelineDesc {
                name: "voxel relax control",
                shader: "voxel/relax_control.comp",
                bindings: &["control"],
                max_sets: 1,
            },
        )?;
        let decide_set = decide.allocate_set(ctx, &[control_write])?;
        let (mut jacobi, mut sweep) = (None, None);
        let (k, blocks) = match params.relaxation {
            Relaxation::Jacobi => {
                let pipeline = ComputePipeline::<RelaxPush>::new_specialized(
                    ctx,
                    &ComputePipelineDesc {
                        name: "voxel relax step",
                        shader: "voxel/relax_step.comp",
                        bindings: &[
                            "grid",
                            "medium",
                            "seed",
                            "state_in",
                            "state_out",
                            "path_in",
                            "path_out",
                            "control",
                            "transport",
                        ],
                        max_sets: 2,
                    },
                    &[
                        SpecConstant::bool(0, params.soft_beta > 0.0),
                        SpecConstant::bool(1, grid.track_path),
                    ],
                )?;
                let set = |from: usize, to: usize| {
                    pipeline.allocate_set(
                        ctx,
                        &[
                            DescriptorWrite::StorageBuffer {
                                name: "grid",
                                buffer: &grid.frame,
                            },
                            DescriptorWrite::storage_image("medium", &grid.medium),
                            DescriptorWrite::storage_image("seed", &grid.seed),
                            DescriptorWrite::storage_image("state_in", &grid.state[from]),
                            DescriptorWrite::storage_image("state_out", &grid.state[to]),
                            DescriptorWrite::storage_image("path_in", &grid.path[from]),
                            DescriptorWrite::storage_image("path_out", &grid.path[to]),
                            control_write,
                            DescriptorWrite::storage_image("transport", &grid.transport),
                        ],
                    )
                };
                let sets = [set(0, 1)?, set(1, 0)?];
                jacobi = Some((pipeline, sets));
                let k = params.block;
                let cap = params
                    .max_iterations
                    .unwrap_or(2 * (d[0] + d[1] + d[2]))
                    .max(k);
                (k, cap.div_ceil(k))
            }
            Relaxation::Sweep => {
                let pipeline = ComputePipeline::<SweepPush>::new(
                    ctx,
                    &ComputePipelineDesc {
                        name: "voxel relax sweep",
                        shader: "voxel/relax_sweep.comp",
                        bindings: &["grid", "medium", "state", "control"],
                        max_sets: 1,
                    },
                )?;
                let set = pipeline.allocate_set(
                    ctx,
                    &[
                        DescriptorWrite::StorageBuffer {
                            name: "grid",
                            buffer: &grid.frame,
                        },
                        DescriptorWrite::storage_image("medium", &grid.medium),
                        DescriptorWrite::storage_image("state", &grid.state[0]),
                        control_write,
                    ],
                )?;
                sweep = Some((pipeline, set));
                let rounds = params
                    .max_iterations
                    .map_or(DEFAULT_SWEEP_ROUNDS, |m| m.div_ceil(SWEEPS_PER_ROUND));
                (SWEEPS_PER_ROUND, rounds)
            }
        };
        let slice_groups = |axis: usize| {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            [d[u].div_ceil(8), d[v].div_ceil(8), 1, 0]
        };
        let initial = RelaxControl {
            groups: [d[0].div_ceil(4), d[1].div_ceil(4), d[2].div_ceil(4)],
            sweep: [slice_groups(0), slice_groups(1), slice_groups(2)],
            ..RelaxControl::default()
        };
        Ok(RelaxPass {
            jacobi,
            sweep,
            decide,
            decide_set,
            control,
            relaxation: params.relaxation,
            beta: params.soft_beta,
            tolerance: params.soft_tolerance,
            k,
            blocks,
            initial,
            big_a: fresnel::boundary_a(eta) as f32,
        })
    }

    /// Changes eta (the diffusion model's boundary constant A).
    pub fn set_eta(&mut self, eta: f64) {
        self.big_a = fresnel::boundary_a(eta) as f32;
    }

    /// Iterations (Jacobi) or sweeps a frame records at most.
    pub fn cap(&self) -> u32 {
        self.k * self.blocks
    }

    /// Reads: the grid frame, the medium, the seed. Reads and writes: both state images (the
    /// result is left in `state[0]`) and both path images (Jacobi).
    /// With `copy_to`, the control record is copied there at the end (host-readable after the
    /// frame: the iterations run).
    pub fn declare<'a>(
        &'a self,
        grid: &'a VoxelGrid,
        copy_to: Option<&'a Buffer>,
    ) -> Vec<ResourceUse<'a>> {
        let mut uses = vec![
            ResourceUse::buffer_span(
                &self.control,
                Access::TransferDst,
                if copy_to.is_some() {
                    Access::TransferSrc
                } else {
                    Access::IndirectArgs
                },
            ),
            ResourceUse::buffer(&grid.frame, Access::ComputeRead),
            ResourceUse::image(&grid.medium, Access::ComputeRead),
            ResourceUse::image(&grid.seed, Access::ComputeRead),
            ResourceUse::image(&grid.state[0], Access::ComputeReadWrite),
        ];
        if self.relaxation == Relaxation::Jacobi {
            // The path images are bound (placeholders without paths): GENERAL either way.
            uses.push(ResourceUse::image(&grid.state[1], Access::ComputeReadWrite));
            uses.push(ResourceUse::image(&grid.path[0], Access::ComputeReadWrite));
            uses.push(ResourceUse::image(&grid.path[1], Access::ComputeReadWrite));
            uses.push(ResourceUse::image(&grid.transport, Access::ComputeRead));
        }
        if let Some(copy) = copy_to {
            uses.push(ResourceUse::buffer_span(
                copy,
                Access::TransferDst,
                Access::HostRead,
            ));
        }
        uses
    }

    /// Records the capped iterations with the GPU's stopping rule.
    ///
    /// # Safety
    /// `cb` must be recording outside a rendering scope, the declared resources in their declared
    /// states and alive until it completes.
    pub unsafe fn record(
        &self,
        ctx: &Context,
        cb: vk::CommandBuffer,
        grid: &VoxelGrid,
        copy_to: Option<&Buffer>,
        profiler: Option<&mut GpuProfiler>,
    ) {
        use vk::AccessFlags2 as A;
        use vk::PipelineStageFlags2 as S;
        let dims = grid.dims.push();
        let raw = ctx.raw();
        let mut profiler = profiler;
        let to_indirect = raw_barrier(
            S::COMPUTE_SHADER | S::COPY,
            A::SHADER_STORAGE_WRITE | A::TRANSFER_WRITE,
            S::DRAW_INDIRECT | S::COMPUTE_SHADER,
            A::INDIRECT_COMMAND_READ | A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
        );
        // SAFETY: the caller's contract; every set's resources live in `self` and `grid`.
        unsafe {
            ctx.begin_label(cb, PASS_RELAX);
            if let Some(p) = profiler.as_deref_mut() {
                p.begin_scope(cb, PASS_RELAX);
            }
            // why: the previous frame's compute and indirect reads of the control record must
            // finish before it is reset (WAR).
            barrier::record(
                ctx,
                cb,
                &[raw_barrier(
                    S::COMPUTE_SHADER | S::DRAW_INDIRECT,
                    A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE | A::INDIRECT_COMMAND_READ,
                    S::COPY,
                    A::TRANSFER_WRITE,
                )],
                &[],
            );
            raw.cmd_update_buffer(cb, self.control.raw, 0, bytemuck::bytes_of(&self.initial));
            // why: the iterations read the reset arguments (indirect, RAW) and count into it.
            barrier::record(ctx, cb, &[to_indirect], &[]);
            for _ in 0..self.blocks {
                if let Some((pipeline, sets)) = &self.jacobi {
                    for j in 0..self.k {
                        if j > 0 {
                            // why: this iteration reads the previous one's output (RAW) and
                            // overwrites what the one before read (WAR).
                            barrier::memory(
                                ctx,
                                cb,
                                Access::ComputeWrite,
                                Access::ComputeReadWrite,
                            );
                        }
                        pipeline.dispatch_indirect(
                            ctx,
                            cb,
                            sets[(j % 2) as usize],
                            &RelaxPush {
                                dims,
                                beta: self.beta,
                                tolerance: self.tolerance,
                                flag_changes: u32::from(j + 1 == self.k),
                                big_a: self.big_a,
                            },
                            &self.control,
                            0,
                        );
                    }
                } else if let Some((pipeline, set)) = &self.sweep {
                    let mut first = true;
                    for axis in 0..3u32 {
                        for step in [1i32, -1] {
                            let offset = std::mem::offset_of!(RelaxControl, sweep) as u64
                                + 16 * u64::from(axis);
                            let n = dims[axis as usize];
                            for s in 1..n {
                                let slice = if step > 0 { s } else { n - 1 - s };
                                if !first {
                                    // why: this slice reads the slice the previous dispatch
                                    // wrote (RAW) in the same image.
                                    barrier::memory(
                                        ctx,
                                        cb,
                                        Access::ComputeWrite,
                                        Access::ComputeReadWrite,
                                    );
                                }
                                first = false;
                                pipeline.dispatch_indirect(
                                    ctx,
                                    cb,
                                    *set,
                                    &SweepPush {
                                        dims,
                                        axis,
                                        step,
                                        slice,
                                        pad: 0,
                                    },
                                    &self.control,
                                    offset,
                                );
                            }
                        }
                    }
                }
                // why: the decision reads the change count the iterations added (RAW).
                barrier::memory(ctx, cb, Access::ComputeWrite, Access::ComputeReadWrite);
                self.decide.dispatch(
                    ctx,
                    cb,
                    self.decide_set,
                    &ControlPush {
                        k: self.k,
                        pad: [0; 3],
                    },
                    [1, 1, 1],
                );
                // why: the next block's indirect dispatches read the arguments the decision wrote
                // (RAW at DRAW_INDIRECT), and its iterations count into the record again.
                barrier::record(ctx, cb, &[to_indirect], &[]);
            }
            if let Some(copy) = copy_to {
                // why: the copy reads the record the decisions wrote (RAW).
                barrier::record(
                    ctx,
                    cb,
                    &[raw_barrier(
                        S::COMPUTE_SHADER | S::DRAW_INDIRECT,
                        A::SHADER_STORAGE_WRITE,
                        S::COPY,
                        A::TRANSFER_READ,
                    )],
                    &[],
                );
                raw.cmd_copy_buffer(
                    cb,
                    self.control.raw,
                    copy.raw,
                    &[vk::BufferCopy::default().size(std::mem::size_of::<RelaxControl>() as u64)],
                );
                // why: the host reads the copy after the frame's fence (RAW across the host
                // boundary).
                barrier::record(
                    ctx,
                    cb,
                    &[raw_barrier(
                        S::COPY,
                        A::TRANSFER_WRITE,
                        S::HOST,
                        A::HOST_READ,
                    )],
                    &[],
                );
            }
            if let Some(p) = profiler {
                p.end_scope(cb);
            }
            ctx.end_label(cb);
        }
    }

    /// Headless, after the frame's submission completed: iterations run, whether it converged.
    pub fn control(&self, ctx: &Context) -> Result<RelaxControl, Error> {
        host_sync(ctx)?;
        Ok(bytemuck::pod_read_unaligned(
            &self.control.read_bytes()?[..std::mem::size_of::<RelaxControl>()],
        ))
    }
}
