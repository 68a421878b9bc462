//! What a GPU solve is asked for: storage precision and [`GpuSolveParams`].

use super::*;
pub use crate::solver::transport::{ExitQuery, SurfaceReconstruction};

/// How phi is stored (DESIGN section 4).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    /// phi RGBA32F, correction sweeps in RGBA16F against the fp32 residual (the default).
    #[default]
    Mixed,
    /// phi RGBA16F ping-pong (the paper's state; stalls on fine levels).
    Fp16,
    /// phi RGBA32F ping-pong.
    Fp32,
}

impl std::str::FromStr for Precision {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "mixed" => Ok(Self::Mixed),
            "fp16" => Ok(Self::Fp16),
            "fp32" => Ok(Self::Fp32),
            _ => Err(SolverError::BadParameter {
                name: "precision",
                problem: format!("'{s}' (expected mixed, fp16 or fp32)"),
            }),
        }
    }
}

/// Where a heterogeneous material's per-channel Jacobi weights come from (issue 13 item 4: speed
/// against memory; `--heterogeneous-weights`). Homogeneous materials use neither (push constants).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum HeterogeneousWeights {
    /// Three RGBA32F textures of weights `a_ik / a_ii`, derived once per edit
    /// (`edit/derive_weights.comp`): 3 weight reads per node and sweep, 48 bytes per texel more.
    Stored,
    /// Derived in every sweep from the fv fractions and per-node kappa and mu (the harmonic face
    /// kappa, `diffusion/graph_weights.glsl`): 8 texel reads per node and sweep, no weight textures.
    #[default]
    Derived,
}

impl std::str::FromStr for HeterogeneousWeights {
    type Err = SolverError;
    fn from_str(s: &str) -> Result<Self, SolverError> {
        match s {
            "stored" => Ok(Self::Stored),
            "derived" => Ok(Self::Derived),
            _ => Err(SolverError::BadParameter {
                name: "heterogeneous_weights",
                problem: format!("'{s}' (expected stored or derived)"),
            }),
        }
    }
}

/// Parameters of [`GpuDiffusion`].
#[derive(Clone, Debug)]
pub struct GpuSolveParams {
    pub scheme: Scheme,
    pub precision: Precision,
    /// Iteration cap per level, coarsest first; the last entry repeats. Rounded up to whole blocks.
    pub iterations: Vec<u32>,
    /// Iterations per block (even, >= 2): the convergence test runs after each block.
    pub block: u32,
    /// Stop a level once (max|dphi| / max|phi|) / (1 - rho) is below this (0: never early).
    pub tolerance: f32,
    /// The boundary model and exit query (DESIGN 2.6): its A and flux gain in the Robin rows,
    /// its exitance in the J+ pass; the same formulas as the f64 reference's
    /// [`crate::solver::transport::Transport::exit`].
    pub exit: ExitQuery,
    /// The lights as the collimated source of DESIGN 2.7 (needs `exit: Moments`): the gather
    /// writes each lit node's particular solution into its Robin row and the exit query's part
    /// of it, which the J+ pass adds back. A heterogeneous field takes each node's own
    /// coefficients (when its kappa and mu images existed as the gather was bound: a material
    /// made heterogeneous by a later edit falls back to the boundary flux).
    pub collimated: bool,
    /// With `collimated`: the second-collision source (DESIGN 2.8's second option, the f64
    /// reference's `transport::Source::SecondCollision`): the first-collision density times the
    /// share of once-scattered light that collides again; pair it with single scattering added
    /// whole (`frame::ScatterMode::Full`).
    pub second_collision: bool,
    /// With `collimated`: lights a node's shadow lookup sees partly occluded (a shadow edge or
    /// the terminator, within about 1.5 shadow texels) enter as the boundary flux (DESIGN 2.7's
    /// fallback where the flat half-space fails).
    pub shadow_edge_flux: bool,
    /// With `collimated`: continuation through walls (the f64 reference's
    /// [`crate::solver::transport::Transport::continuation`], DESIGN 2.7's thin walls): a node
    /// facing away from a light gets the attenuated particular solution of the beam that entered
    /// on the light's side (the entry from the light's shadow view). Exact for a slab at any
    /// thickness, where the boundary-flux fallback is 0.84-0.89 of Monte Carlo and the beam
    /// without it 1.06-2.3x below 4 mean free paths (benches/thinwall/slab_rule.py).
    pub continuation: bool,
    /// With `collimated`: each lit node's beam taken from upstream on the curved surface (the
    /// f64 reference's [`crate::solver::transport::Transport::upstream_beam`], the same
    /// formula and the same baked curvature per node).
    pub upstream_beam: bool,
    /// With `upstream_beam`: the curved particular solution (the f64 reference's
    /// [`crate::solver::transport::Transport::curved_particular`], the same formulas).
    pub curved_particular: bool,
    /// With `collimated` and the interior surface: each display vertex's collimated part P at
    /// its own light visibility (the gather run at the display vertices too,
    /// `solver::gpu::interior::VertexGather`), not its source nodes' (the f64 reference's
    /// [`crate::solver::transport::Transport::own_visibility`], the same formula). One light.
    pub own_visibility: bool,
    /// `Some`: multigrid cycles (`--schedule multigrid`, [`super::multigrid`]) with these
    /// parameters (its tolerance is this struct's `tolerance`; `krylov` is not built on the GPU
    /// and ignored; `coarse_tolerance` sets the coarsest level's Chebyshev steps); `None`: the
    /// paper's cascade.
    pub multigrid: Option<crate::solver::multigrid::MultigridParams>,
    /// How the display vertices get their exitance: `Interior` (phi from a point a fixed depth
    /// inside and the local 1D profile, `diffusion/vertex_interior*.comp`, the f64 reference's
    /// [`crate::solver::transport::SurfaceReconstruction::Interior`]; `--surface interior`) or
    /// `Shepard` (the surface nodes' J+ through the shading weights; the default, as the f64
    /// reference's `Transport::default()`: closer to the path-traced references so far). A graph without surface samples
    /// (built by hand, not baked) uses `Shepard`. `DepthSample` is CPU only.
    pub surface: SurfaceReconstruction,
    /// Stored or per-sweep derived weights of a heterogeneous material (cascade schedule; the
    /// multigrid schedule builds its operator on the CPU and reads neither).
    pub heterogeneous_weights: HeterogeneousWeights,
}

impl GpuSolveParams {
    /// The f64 reference's transport the GPU frame computes with these parameters (render
    /// `--solver cpu` with the same `--source`, `--exit-query` and `--surface`): with a beam
    /// source [`crate::solver::transport::Transport::gpu_collimated`] (the second-collision
    /// source with `second_collision`), else the boundary flux read by `exit`.
    pub fn transport(&self) -> crate::solver::transport::Transport {
        use crate::solver::transport::{Source, Transport};
        let base = if self.collimated {
            Transport {
                source: if self.second_collision {
                    Source::SecondCollision
                } else {
                    Source::Collimated
                },
                ..Transport::gpu_collimated()
            }
        } else {
            Transport {
                exit: self.exit,
                ..Transport::default()
            }
        };
        // The beam's shape as the frame gathers it (the report's energy reads the same
        // sources: with the curved default the transmitted input differs per channel).
        let beam = |t: Transport| Transport {
            continuation: self.continuation,
            upstream_beam: self.upstream_beam,
            curved_particular: self.curved_particular,
            ..t
        };
        Transport {
            surface: self.surface,
            own_visibility: self.own_visibility,
            ..if self.collimated { beam(base) } else { base }
        }
    }
}

impl Default for GpuSolveParams {
    fn default() -> Self {
        Self {
            scheme: Scheme::Fv,
            precision: Precision::Mixed,
            iterations: vec![200],
            block: 8,
            tolerance: 1e-4,
            exit: ExitQuery::default(),
            collimated: false,
            second_collision: false,
            shadow_edge_flux: false,
            continuation: false,
            upstream_beam: false,
            curved_particular: false,
            own_visibility: false,
            multigrid: None,
            surface: SurfaceReconstruction::Shepard,
            heterogeneous_weights: HeterogeneousWeights::default(),
        }
    }
}
