#version 460
#extension GL_GOOGLE_include_directive : require
// Heterogeneous material: the per-channel Jacobi weights w_ik = a_ik / a_ii of every texel from the
// geometric factors (weight_geo, frac: what the bake or edit/deform_geometry.comp wrote) and the
// per-node material (kappa, mu) (DESIGN section 2, fv; paper Eqs. 5/6 for the paper scheme):
//   fv inner:    kappa_ij = 1 / (t_ij / kappa_i + (1 - t_ij) / kappa_j), t_ij = delta_i / (delta_i + delta_j)
//                (the harmonic mean across the face; t = 1 when j is a surface node: kappa_i),
//                a_ij = g_ij kappa_ij, a_ii = sum_j a_ij + mu_i
//   paper inner: a_ij = g_ij kappa_j, a_ii = kappa_i sum_j g_ij + mu_i
//   surface s of cell k: a_sk = 2A g_s0 kappa (kappa_k for fv, kappa_s for paper), a_ss = 1 + a_sk,
//                slot 1 = q_gain / a_ss (Eq. 9's source gain).
// Runs once per material edit or deformation, never per Jacobi iteration: the iteration keeps its
// three weight reads per texel.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32ui) uniform readonly uimage2D connectivity;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D geo;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D frac;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D kappa;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D mu;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D weight_r;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D weight_g;
layout(set = 0, binding = 7, rgba32f) uniform writeonly image2D weight_b;

layout(push_constant) uniform DerivePush {
    ivec2 size;
    uint width;
    uint surface_rows;
    uint paper;
    float two_a;
    float q_gain;
    uint pad;
} pc;

ivec2 texel_of(uint linear) {
    return ivec2(int(linear % pc.width), int(linear / pc.width));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    uvec4 nb = imageLoad(connectivity, p);
    uint self_index = uint(p.y) * pc.width + uint(p.x);
    vec4 w[3] = vec4[3](vec4(0.0), vec4(0.0), vec4(0.0));
    // Padding texels point to themselves (no node is its own neighbour): weights stay 0.
    if (nb.x != self_index) {
        vec4 g = imageLoad(geo, p);
        vec3 k_i = imageLoad(kappa, p).rgb;
        if (uint(p.y) < pc.surface_rows) {
            vec3 k = pc.paper != 0u ? k_i : imageLoad(kappa, texel_of(nb.x)).rgb;
            vec3 off = pc.two_a * g[0] * k;
            vec3 diag = 1.0 + off;
            for (int c = 0; c < 3; ++c) {
                w[c][0] = off[c] / diag[c];
                w[c][1] = pc.q_gain / diag[c];
            }
        } else {
            vec4 t = imageLoad(frac, p);
            vec3 off[4];
            vec3 diag = imageLoad(mu, p).rgb;
            for (int k = 0; k < 4; ++k) {
                ivec2 q = texel_of(nb[k]);
                vec3 k_j = imageLoad(kappa, q).rgb;
                vec3 k_ij;
                if (pc.paper != 0u) {
                    k_ij = k_j;
                    diag += k_i * g[k];
                } else {
                    k_ij = t[k] >= 1.0 ? k_i : 1.0 / (t[k] / k_i + (1.0 - t[k]) / k_j);
                }
                off[k] = g[k] * k_ij;
                if (pc.paper == 0u) {
                    diag += off[k];
                }
            }
            for (int k = 0; k < 4; ++k) {
                for (int c = 0; c < 3; ++c) {
                    w[c][k] = off[k][c] / diag[c];
                }
            }
        }
    }
    imageStore(weight_r, p, w[0]);
    imageStore(weight_g, p, w[1]);
    imageStore(weight_b, p, w[2]);
}
