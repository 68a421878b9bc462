// The Jacobi weights of a texel (DESIGN section 4), one shader for both material kinds: the
// specialization constant HOMOGENEOUS (constant_id 0) picks the path when the pipeline is created.
// - HOMOGENEOUS = false: weight_r/g/b hold w_ik = a_ik / a_ii per channel (derived on the GPU by
//   edit/derive_weights.comp from geometry and per-node material), a surface row's slot 1 its
//   source gain.
// - HOMOGENEOUS = true (one material everywhere): only weight_geo is read. It holds the geometric
//   factor g_ik of each slot (A_f / (V_i d_ij) for fv, 1 / d_ij^2 for the paper scheme, 1 / d_sk
//   on surface rows); kappa, 2A and mu come from push constants:
//   inner a_ik = kappa g_ik, a_ii = kappa sum_k g_ik + mu; surface a_s0 = 2A kappa g_s0,
//   a_ss = 1 + a_s0 (paper Eq. 6 over d_sk), gain = q_gain / a_ss.
//   16 bytes read per texel instead of 48, and no per-node material. The per-channel bindings stay
//   declared (one module), bound by the host to a NaN-filled 1x1 image: a read would poison phi.
// - HOMOGENEOUS = false, DERIVED = true (constant_id 1; `HeterogeneousWeights::Derived`): no stored
//   weights; the three per-channel bindings hold the fv fractions (weight_r), per-node kappa
//   (weight_g) and mu (weight_b), and the weights are derived here in every sweep exactly as
//   edit/derive_weights.comp derives the stored ones (same operations, same order): 48 bytes per
//   texel less, 8 texel reads per node instead of 3. PAPER (constant_id 2) selects the paper
//   scheme's form there.
// Include after graph_common.glsl (or a kernel's own `pc` with width, kappa and mu_gain, and
// `texel_of`).
#ifndef GRAPH_WEIGHTS_GLSL
#define GRAPH_WEIGHTS_GLSL

// A kernel with constants and bindings of its own at these numbers moves them (the multigrid's
// matrix-free finest level, multigrid/graph_operator.glsl): define both before the include.
#ifndef GRAPH_WEIGHTS_CONSTANT_ID
#define GRAPH_WEIGHTS_CONSTANT_ID 0
#endif
#ifndef GRAPH_WEIGHTS_BINDING
#define GRAPH_WEIGHTS_BINDING 10
#endif

layout(constant_id = GRAPH_WEIGHTS_CONSTANT_ID) const bool HOMOGENEOUS = false;
layout(constant_id = GRAPH_WEIGHTS_CONSTANT_ID + 1) const bool DERIVED = false;
layout(constant_id = GRAPH_WEIGHTS_CONSTANT_ID + 2) const bool PAPER = false;

layout(set = 0, binding = GRAPH_WEIGHTS_BINDING, rgba32f) uniform readonly image2D weight_geo;
layout(set = 0, binding = GRAPH_WEIGHTS_BINDING + 1, rgba32f) uniform readonly image2D weight_r;
layout(set = 0, binding = GRAPH_WEIGHTS_BINDING + 2, rgba32f) uniform readonly image2D weight_g;
layout(set = 0, binding = GRAPH_WEIGHTS_BINDING + 3, rgba32f) uniform readonly image2D weight_b;

// Heterogeneous, DERIVED: edit/derive_weights.comp's formulas, read from the fractions, kappa and mu.
void derived_weights(ivec2 p, uvec4 nb, bool surface, out vec3 w[4], out vec3 gain) {
    for (int k = 0; k < 4; ++k) {
        w[k] = vec3(0.0);
    }
    gain = vec3(0.0);
    // Padding texels point to themselves (no node is its own neighbour): weights stay 0.
    if (nb.x == uint(p.y) * pc.width + uint(p.x)) {
        return;
    }
    vec4 g = imageLoad(weight_geo, p);
    vec3 k_i = imageLoad(weight_g, p).rgb;
    if (surface) {
        vec3 k = PAPER ? k_i : imageLoad(weight_g, texel_of(nb.x)).rgb;
        vec3 off = pc.kappa.a * g[0] * k;
        vec3 diag = 1.0 + off;
        w[0] = off / diag;
        gain = pc.mu_gain.a / diag;
        return;
    }
    vec4 t = imageLoad(weight_r, p);
    vec3 off[4];
    vec3 diag = imageLoad(weight_b, p).rgb;
    for (int k = 0; k < 4; ++k) {
        vec3 k_j = imageLoad(weight_g, texel_of(nb[k])).rgb;
        vec3 k_ij;
        if (PAPER) {
            k_ij = k_j;
            diag += k_i * g[k];
        } else {
            k_ij = t[k] >= 1.0 ? k_i : 1.0 / (t[k] / k_i + (1.0 - t[k]) / k_j);
        }
        off[k] = g[k] * k_ij;
        // (No `!PAPER`: an operation on a specialization constant is a spec-constant op, which
        // the reflection cannot evaluate.)
        if (PAPER) {
        } else {
            diag += off[k];
        }
    }
    for (int k = 0; k < 4; ++k) {
        w[k] = off[k] / diag;
    }
}

void node_weights(ivec2 p, uvec4 nb, bool surface, out vec3 w[4], out vec3 gain) {
    if (HOMOGENEOUS) {
        vec4 g = imageLoad(weight_geo, p);
        vec3 kappa = pc.kappa.rgb;
        if (surface) {
            g[0] *= pc.kappa.a; // 2A: the Robin coefficient (eta-dependent, so not in the texture)
        }
        vec3 diag = surface ? 1.0 + kappa * g[0] : kappa * (g[0] + g[1] + g[2] + g[3]) + pc.mu_gain.rgb;
        // Padding has g = 0; with mu = 0 its diagonal is 0: keep the weights 0, not 0/0.
        vec3 inv = 1.0 / max(diag, vec3(1e-30));
        for (int k = 0; k < 4; ++k) {
            w[k] = (surface && k > 0) ? vec3(0.0) : kappa * g[k] * inv;
        }
        gain = surface ? pc.mu_gain.a * inv : vec3(0.0);
    } else if (DERIVED) {
        derived_weights(p, nb, surface, w, gain);
    } else {
        vec4 wr = imageLoad(weight_r, p);
        vec4 wg = imageLoad(weight_g, p);
        vec4 wb = imageLoad(weight_b, p);
        for (int k = 0; k < 4; ++k) {
            w[k] = vec3(wr[k], wg[k], wb[k]);
        }
        gain = surface ? w[1] : vec3(0.0);
    }
}

// Eqs. 8/9's neighbour sum, ACC += sum_k w_ik x_nbr(i,k), of image IMG (surface rows have one
// neighbour; padding has zero weights). A macro, not a function: the Jacobi, residual and
// correction passes each read a different image (the ping-pong state, phi, the correction).
#define ADD_NEIGHBOUR_SUM(ACC, IMG, NB, W, SURFACE)                          \
    for (int k_ = 0; k_ < ((SURFACE) ? 1 : 4); ++k_) {                       \
        ACC += W[k_] * imageLoad(IMG, texel_of(NB[k_])).rgb;                 \
    }

#endif
