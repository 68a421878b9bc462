// The Jacobi weights of a texel, from the weight textures (DESIGN section 4).
// Default: weight_r/g/b hold w_ik = a_ik / a_ii per channel (f64 on the CPU), a surface row's
// slot 1 its source gain. With HOMOGENEOUS (one material everywhere): weight_geo holds the
// geometric factor g_ik = a_ik / kappa of each slot (A_f / (V_i d_ij) for fv, 1 / d_ij^2 for the
// paper scheme, 2 A / d_sk on surface rows), and kappa, mu come from push constants:
// inner a_ii = kappa sum_k g_ik + mu, surface a_ss = 1 + kappa g_s0, gain = q_gain / a_ss.
// 16 bytes per texel instead of 48. Include after graph_common.glsl.
#ifndef GRAPH_WEIGHTS_GLSL
#define GRAPH_WEIGHTS_GLSL

#ifdef HOMOGENEOUS
layout(set = 0, binding = 10, rgba32f) uniform readonly image2D weight_geo;
#else
layout(set = 0, binding = 10, rgba32f) uniform readonly image2D weight_r;
layout(set = 0, binding = 11, rgba32f) uniform readonly image2D weight_g;
layout(set = 0, binding = 12, rgba32f) uniform readonly image2D weight_b;
#endif

void node_weights(ivec2 p, bool surface, out vec3 w[4], out vec3 gain) {
#ifdef HOMOGENEOUS
    vec4 g = imageLoad(weight_geo, p);
    vec3 kappa = pc.kappa.rgb;
    vec3 diag = surface ? 1.0 + kappa * g[0] : kappa * (g[0] + g[1] + g[2] + g[3]) + pc.mu_gain.rgb;
    // Padding has g = 0; with mu = 0 its diagonal is 0: keep the weights 0, not 0/0.
    vec3 inv = 1.0 / max(diag, vec3(1e-30));
    for (int k = 0; k < 4; ++k) {
        w[k] = kappa * g[k] * inv;
    }
    gain = surface ? pc.mu_gain.a * inv : vec3(0.0);
#else
    vec4 wr = imageLoad(weight_r, p);
    vec4 wg = imageLoad(weight_g, p);
    vec4 wb = imageLoad(weight_b, p);
    for (int k = 0; k < 4; ++k) {
        w[k] = vec3(wr[k], wg[k], wb[k]);
    }
    gain = surface ? w[1] : vec3(0.0);
#endif
}

#endif
