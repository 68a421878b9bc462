//! Push constants of the diffusion passes and the per-level control record the GPU writes
//! (indirect arguments, iterations, convergence); their layouts match `shaders-glsl/diffusion/`.

/// Push constants of the per-level diffusion passes (`diffusion/*.comp`, `graph_common.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LevelPush {
    pub size: [i32; 2],
    pub width: u32,
    pub surface_rows: u32,
    /// Homogeneous material only (`graph_weights.glsl`): kappa per channel, 2A in a.
    pub kappa: [f32; 4],
    /// Homogeneous material only: mu per channel, q_gain = 4 / (1 - F_dr) in a.
    pub mu_gain: [f32; 4],
}

/// Push constants of `shepard/init_phi*.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShepardPush {
    pub size: [i32; 2],
    pub coarse_width: u32,
    /// 1: write zero (coarsest level, no warm start).
    pub zero: u32,
}

/// Push constants of `shepard/warm_correct*.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct WarmPush {
    pub size: [i32; 2],
    pub coarse_width: u32,
    /// Bit 0 ([`WARM_CORRECT`]): add the coarser level's change; bit 1 ([`WARM_SAVE`]): first
    /// save this level's phi for the next finer level's correction.
    pub flags: u32,
}

/// [`WarmPush::flags`]: add P(coarse new - coarse previous) to this level's phi.
pub const WARM_CORRECT: u32 = 1;
/// [`WarmPush::flags`]: save this level's phi (before the correction) for the finer level.
pub const WARM_SAVE: u32 = 2;

/// Push constants of `reduce/convergence*.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ReducePush {
    pub size: [i32; 2],
    pub level: u32,
    pub k: u32,
    pub tolerance: f32,
}

/// Push constants of `diffusion/j_plus*.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct JPlusPush {
    pub size: [i32; 2],
    pub surface_rows: u32,
    pub inv_q_scale: f32,
    pub phi_factor: f32,
    pub q_factor: f32,
    /// The collimated source (DESIGN 2.7): the shading input per unit exitance, times the
    /// `particular` image's value, is added to J+; 0: not read.
    pub particular_factor: f32,
    /// The Robin right-hand side per unit q ([`crate::solver::transport::Boundary::flux_gain`]),
    /// for the per-node exit lobe's diffused share (the J+ image's alpha).
    pub flux_gain: f32,
}

/// Push constants of `diffusion/vertex_j_plus.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct VertexPush {
    pub count: u32,
    pub width: u32,
    /// Floats per vertex in the output buffer and the float offset of J+ in a vertex.
    pub stride: u32,
    pub offset: u32,
    /// 1: also write the diffused share (the J+ image's alpha) at float offset + 3 (the solver's
    /// own vec4 buffer only).
    pub share: u32,
}

/// Push constants of `diffusion/vertex_interior*.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct InteriorPush {
    pub count: u32,
    pub width: u32,
    /// Floats per vertex in the output buffer and the float offset of J+ in a vertex.
    pub stride: u32,
    pub offset: u32,
    /// Homogeneous: D rgb; a: 1 = read the kappa / mu images (heterogeneous).
    pub kappa: [f32; 4],
    /// Homogeneous: sigma_a rgb; a: 2A.
    pub mu: [f32; 4],
    /// The exit query M = x phi0 + y D dphi0 - z q; w: the flux gain (rhs = w q).
    pub exit: [f32; 4],
    /// x: 1 / q_scale, y: shading input per unit exitance, z: 1 = add the collimated part.
    pub scale: [f32; 4],
}

/// One level's record in the control buffer (`LevelControl` in `reduce/convergence.glsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LevelControl {
    /// `VkDispatchIndirectCommand` of the level's iteration dispatches.
    pub groups: [u32; 3],
    pub iterations: u32,
    pub blocks: u32,
    pub rel_previous: f32,
    /// Error estimate after the last block that ran (f32::MAX-like when not contracting yet).
    pub estimate: f32,
    /// 0 running or at the cap, [`Self::CONVERGED`] or [`Self::STALLED`].
    pub stopped_early: u32,
}

impl LevelControl {
    /// `stopped_early`: the estimated error reached the tolerance.
    pub const CONVERGED: u32 = 1;
    /// `stopped_early`: a block changed nothing while the state's rounding is above the
    /// tolerance (fp16 phi: the update rounds to zero before the error is small).
    pub const STALLED: u32 = 2;
}

/// What the last [`GpuDiffusion::record`] put in the command buffer (for tests and reports).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RecordStats {
    /// Iteration dispatches (Jacobi, or residual + correction sweeps + apply in `Mixed`).
    pub iteration_dispatches: u32,
    /// Memory barriers recorded in front of iteration dispatches.
    pub iteration_barriers: u32,
    /// Blocks recorded (each followed by one reduction and one indirect-argument barrier).
    pub blocks: u32,
    /// Iterations the recorded blocks can run at most (blocks x k).
    pub iterations_recorded: u32,
    /// The solve started from the previous solution (a requested warm start falls back to a cold
    /// one when a level to iterate holds no solution at the current exposure).
    pub warm: bool,
    /// Warm start: levels whose start was corrected by the coarser level's change.
    pub corrected_levels: u32,
}
