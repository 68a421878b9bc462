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
// Include after graph_common.glsl.
#ifndef GRAPH_WEIGHTS_GLSL
#define GRAPH_WEIGHTS_GLSL

layout(constant_id = 0) const bool HOMOGENEOUS = false;

layout(set = 0, binding = 10, rgba32f) uniform readonly image2D weight_geo;
layout(set = 0, binding = 11, rgba32f) uniform readonly image2D weight_r;
layout(set = 0, binding = 12, rgba32f) uniform readonly image2D weight_g;
layout(set = 0, binding = 13, rgba32f) uniform readonly image2D weight_b;

void node_weights(ivec2 p, bool surface, out vec3 w[4], out vec3 gain) {
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
