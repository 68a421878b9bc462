// Shared by the multigrid cycle's kernels (DESIGN 5.1, engine/src/solver/gpu/multigrid.rs): the
// push constants (`MultigridPush`) and the control record (`MultigridControl`). Every level's
// vectors live in one buffer each, level `l` at node offset `offset`; one invocation per node.

#define NO_NODE 0xffffffffu

// The per-node RGB vectors (x, f, r, d, the CG's, partner_value) are float arrays, node i at
// floats VECTOR_STRIDE i: 3 (VectorStorage::Rgb, no padding lane) or 4 (VectorStorage::Rgba)
// (`solver::gpu::multigrid`, benches/RESULTS.md "Multigrid storage (wave 7)").
layout(constant_id = 2) const uint VECTOR_STRIDE = 3u;
// A packed prolongation link's weight: its low 8 bits `c` hold (c - 85) / 85
// (LINK_WEIGHT_ZERO, LINK_WEIGHT_STEPS in solver/multigrid/mod.rs), the coarse node the rest.
#define LINK_WEIGHT(link) (float(int((link) & 255u) - 85) / 85.0)
#define RGB(buf, i) \
    vec3(buf.v[VECTOR_STRIDE * (i)], buf.v[VECTOR_STRIDE * (i) + 1u], \
         buf.v[VECTOR_STRIDE * (i) + 2u])
#define SET_RGB(buf, i, value) \
    do { \
        uint at_ = VECTOR_STRIDE * (i); \
        vec3 rgb_ = (value); \
        buf.v[at_] = rgb_.x; \
        buf.v[at_ + 1u] = rgb_.y; \
        buf.v[at_ + 2u] = rgb_.z; \
    } while (false)
// The same RGB read through a uniform texel buffer of R32 floats over the same buffer
// (`TEXEL_READS` in the kernels that have it; `solver::gpu::multigrid::texels`).
#define RGB_TEXELS(tex, i) \
    vec3(texelFetch(tex, int(VECTOR_STRIDE * (i))).x, texelFetch(tex, int(VECTOR_STRIDE * (i) + 1u)).x, \
         texelFetch(tex, int(VECTOR_STRIDE * (i) + 2u)).x)
// The vectors that tolerate fp16 (UpdateStorage::F16, `--update-storage f16`: the smoother's
// update d and the CG's last z, `z_old`) are uint arrays: fp16 RGB in two uints (r|g, b|0) per
// node, or (F32) the bits of VECTOR_STRIDE floats as RGB above.
layout(constant_id = 8) const bool HALF_UPDATES = false;
#define LOAD_UPDATE(buf, i) \
    (HALF_UPDATES ? vec3(unpackHalf2x16(buf.v[2u * (i)]), unpackHalf2x16(buf.v[2u * (i) + 1u]).x) \
                  : uintBitsToFloat(uvec3(buf.v[VECTOR_STRIDE * (i)], \
                                          buf.v[VECTOR_STRIDE * (i) + 1u], \
                                          buf.v[VECTOR_STRIDE * (i) + 2u])))
#define STORE_UPDATE(buf, i, value) \
    do { \
        vec3 u_ = (value); \
        if (HALF_UPDATES) { \
            buf.v[2u * (i)] = packHalf2x16(u_.xy); \
            buf.v[2u * (i) + 1u] = packHalf2x16(vec2(u_.z, 0.0)); \
        } else { \
            uint at_ = VECTOR_STRIDE * (i); \
            buf.v[at_] = floatBitsToUint(u_.x); \
            buf.v[at_ + 1u] = floatBitsToUint(u_.y); \
            buf.v[at_ + 2u] = floatBitsToUint(u_.z); \
        } \
    } while (false)
// A coarse level's fp16 entry (`values16`, r|g, b|c) carries its column in its top 16 bits, the
// node's index in its level (at pc.offset), where every fp16 level has at most 65536 nodes
// (`pack_operators`; `TRANSLUCENT_MULTIGRID_COLUMNS`): the row reads one record per entry instead
// of the record and `cols`. Else `cols` holds it (global).
layout(constant_id = 11) const bool PACKED_COLUMNS = false;
#define HALF_COLUMN(h, cols_e) (PACKED_COLUMNS ? pc.offset + ((h).y >> 16) : (cols_e))
#define MAX_LEVELS 8
#define MAX_LOG 64

layout(push_constant) uniform MultigridPush {
    // Invocations (nodes of the level the kernel runs over).
    uint count;
    // First node of that level in the concatenated vectors.
    uint offset;
    // Kernel-specific switch (see each kernel).
    uint mode;
    // Finest level: texture width (rhs, output, graph_operator.glsl); check: number of partial sums.
    uint width;
    // Chebyshev / damped Jacobi step: d = alpha d + beta B^-1 r (per channel).
    vec4 alpha;
    vec4 beta;
    // check: stop below this relative residual.
    float tolerance;
    // check: stop after this many logged residuals.
    uint max_log;
    // krylov: workgroup sums per block of `partials`.
    uint sums;
    // The finest level's graph (graph_operator.glsl): texel rows holding surface nodes, and the
    // homogeneous material's kappa (2A in a) and mu (q_gain in a), as the cascade's LevelPush.
    uint surface_rows;
    vec4 kappa;
    vec4 mu_gain;
    // check: also stop below this fraction of the first logged residual (the solve's start; 0:
    // off). A warm solve of a small increment of f (`render --bounce source`'s second solve)
    // converges relative to the increment rather than to the whole f.
    float start_tolerance;
} pc;

struct MultigridControl {
    // Per level the VkDispatchIndirectCommand of one invocation per node (x = groups of 64).
    uvec4 args[MAX_LEVELS];
    // ||f||^2 per channel of the finest level (rgb).
    vec4 reference;
    // Residuals logged so far.
    uint logged;
    // 0 running, 1 converged, 2 diverged or not finite, 3 cycle cap reached.
    uint state;
    // Finest nodes the warm start's local relaxation listed (local.comp; 0 without it).
    uint local_nodes;
    // The warm start's order (written by the host with the record's reset; no kernel reads it).
    uint warm_order;
    // Conjugate gradients (krylov.comp): R . z of the current direction, the step alpha and the
    // direction update beta, per channel.
    vec4 rz;
    vec4 alpha;
    vec4 beta;
    // dir . K dir of the current direction (the next iteration's recurrence reads it).
    vec4 dkd;
    // Relative residual after the start (cold: after full multigrid) and after every V-cycle.
    float residual[MAX_LOG];
};
