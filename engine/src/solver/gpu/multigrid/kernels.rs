//! The multigrid's kernels: their pipeline indices and modes, their shaders with the bindings
//! each reads, and the storage buffers by name
//! ([`GpuMultigrid::new`](super::GpuMultigrid::new) builds one pipeline and descriptor set per
//! [`KERNELS`] entry, specialized from its bindings).

/// The levels whose Chebyshev steps run as one `multigrid/relax.comp` pass each (the residual
/// formed where the step uses it, not stored) instead of a residual pass and a step pass
/// (benches/RESULTS.md "Cheaper multigrid passes (wave 10)": fewer passes, but slower on
/// lavapipe). The environment variable `TRANSLUCENT_MULTIGRID_RELAX`, read when the solver is
/// created, picks it for measurements: unset or `split` ([`Self::None`], the default), `fused`
/// ([`Self::Finest`]), `all` ([`Self::AboveCoarsest`]).
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(crate) enum RelaxLevels {
    /// Two passes per step everywhere.
    None,
    /// The finest level's steps fused.
    Finest,
    /// Every level's but the coarsest (whose solve is `coarse.comp`'s).
    AboveCoarsest,
}

impl RelaxLevels {
    pub(super) fn from_env() -> Self {
        match std::env::var("TRANSLUCENT_MULTIGRID_RELAX").as_deref() {
            Ok("fused") => Self::Finest,
            Ok("all") => Self::AboveCoarsest,
            _ => Self::None,
        }
    }
}

/// Pipeline indices into [`GpuMultigrid::pipelines`](super::GpuMultigrid::pipelines).
pub(super) const RHS: usize = 0;
pub(super) const RESIDUAL: usize = 1;
pub(super) const SMOOTH: usize = 2;
pub(super) const RESTRICT: usize = 3;
pub(super) const PROLONG: usize = 4;
pub(super) const NORM: usize = 5;
pub(super) const CHECK: usize = 6;
pub(super) const OUTPUT: usize = 7;
pub(super) const KRYLOV: usize = 8;
pub(super) const LOCAL: usize = 9;
pub(super) const COARSE: usize = 10;
pub(super) const RELAX: usize = 11;

/// Mode of `multigrid/prolong.comp`: r = x + P e on the fine level (a fused post-smoothing run
/// of an odd count of steps starts there; 0: x += P e, 1: x = P e).
pub(super) const PROLONG_INTO_R: u32 = 2;
/// Modes of `multigrid/krylov.comp` (see the shader).
pub(super) const CG_START: u32 = 0;
pub(super) const CG_APPLY: u32 = 1;
pub(super) const CG_STEP: u32 = 2;
pub(super) const CG_START_RESIDUAL: u32 = 3;
pub(super) const CG_FINISH: u32 = 5;
/// Modes of `multigrid/rhs.comp`: a warm start from the last solution, a cold start (x = 0), a
/// warm start extrapolated through `x_history` (`RHS_EXTRAPOLATE + slots - 1`).
pub(super) const RHS_WARM: u32 = 0;
pub(super) const RHS_COLD: u32 = 1;
pub(super) const RHS_EXTRAPOLATE: u32 = 2;
/// Modes of `multigrid/check.comp`.
pub(super) const CHECK_REFERENCE: u32 = 0;
pub(super) const CHECK_RESIDUAL: u32 = 1;
pub(super) const CHECK_CG: u32 = 2;
/// Blocks of workgroup sums the CG apply pass writes (`partials` holds this many times the
/// finest level's workgroups).
pub(super) const CG_SUMS: usize = 4;

/// Shader, binding names (the buffers by name in [`BUFFER_NAMES`], `q` and `phi` the images).
pub(super) const KERNELS: [(&str, &str, &[&str]); 12] = [
    (
        "multigrid rhs",
        "multigrid/rhs.comp",
        &["q", "f", "x", "node_texel", "rhs_coef", "x_history"],
    ),
    (
        "multigrid residual",
        "multigrid/residual.comp",
        &[
            "x",
            "f",
            "r",
            "row_start",
            "cols",
            "values",
            "diag",
            "values16",
            "connectivity",
            "node_texel",
            "texel_node",
            "weight_geo",
            "weight_r",
            "weight_g",
            "weight_b",
            "x_t",
            "f_t",
            "diag_t",
            "row_start_t",
            "cols_t",
            "values_t",
            "values16_t",
            "node_texel_t",
            "texel_node_t",
        ],
    ),
    (
        "multigrid smooth",
        "multigrid/smooth.comp",
        &[
            "x",
            "d",
            "r",
            "diag",
            "partner",
            "partner_value",
            "f",
            "r_t",
            "diag_t",
            "partner_t",
            "partner_value_t",
            "f_t",
        ],
    ),
    (
        "multigrid restrict",
        "multigrid/restrict.comp",
        &["x", "f", "r", "t_start", "t_link", "links", "link_weights"],
    ),
    (
        "multigrid prolong",
        "multigrid/prolong.comp",
        &["x", "links", "link_weights", "r"],
    ),
    (
        "multigrid norm",
        "multigrid/norm.comp",
        &["f", "r", "partials"],
    ),
    (
        "multigrid check",
        "multigrid/check.comp",
        &["partials", "control"],
    ),
    (
        "multigrid output",
        "multigrid/output.comp",
        &["phi", "x", "node_texel"],
    ),
    (
        "multigrid krylov",
        "multigrid/krylov.comp",
        &[
            "x",
            "f",
            "r",
            "sol",
            "dir",
            "z_old",
            "row_start",
            "cols",
            "values",
            "diag",
            "partials",
            "control",
            "kdir",
            "connectivity",
            "node_texel",
            "texel_node",
            "weight_geo",
            "weight_r",
            "weight_g",
            "weight_b",
            "x_t",
            "diag_t",
            "row_start_t",
            "cols_t",
            "values_t",
            "node_texel_t",
            "texel_node_t",
        ],
    ),
    (
        "multigrid local",
        "multigrid/local.comp",
        &[
            "x",
            "f",
            "r",
            "row_start",
            "cols",
            "values",
            "diag",
            "partner",
            "partner_value",
            "control",
            "local",
            "connectivity",
            "node_texel",
            "texel_node",
            "weight_geo",
            "weight_r",
            "weight_g",
            "weight_b",
        ],
    ),
    (
        "multigrid coarse",
        "multigrid/coarse.comp",
        &[
            "x",
            "d",
            "r",
            "f",
            "row_start",
            "cols",
            "values",
            "diag",
            "values16",
            "partner",
            "partner_value",
            "control",
        ],
    ),
    (
        // `x_out` is the `r` buffer (the second set: `x` the `r` buffer, `x_out` the `x` one).
        "multigrid relax",
        "multigrid/relax.comp",
        &[
            "x",
            "x_out",
            "d",
            "f",
            "row_start",
            "cols",
            "values",
            "diag",
            "values16",
            "partner",
            "partner_value",
            "connectivity",
            "node_texel",
            "texel_node",
            "weight_geo",
            "weight_r",
            "weight_g",
            "weight_b",
        ],
    ),
];

/// The storage buffers, in the order [`GpuMultigrid::buffers`](super::GpuMultigrid::buffers)
/// holds them.
pub(super) const BUFFER_NAMES: [&str; 24] = [
    "x",
    "f",
    "r",
    "d",
    "row_start",
    "cols",
    "values",
    "diag",
    "partner",
    "partner_value",
    "links",
    "link_weights",
    "t_start",
    "t_link",
    "node_texel",
    "rhs_coef",
    "partials",
    "sol",
    "dir",
    "z_old",
    "kdir",
    "values16",
    "x_history",
    "texel_node",
];

/// The per-node RGB vectors, `VectorStorage`'s stride each (`VECTOR_STRIDE` in `common.glsl`).
pub(super) const VECTORS: [&str; 10] = [
    "x",
    "f",
    "r",
    "d",
    "sol",
    "dir",
    "z_old",
    "kdir",
    "partner_value",
    "x_history",
];

/// The buffers the kernels write (the others are written once, from the host).
pub(super) const WRITTEN: [&str; 10] = [
    "x",
    "f",
    "r",
    "d",
    "partials",
    "sol",
    "dir",
    "z_old",
    "kdir",
    "x_history",
];
