#version 460
#extension GL_GOOGLE_include_directive : require
// Mixed precision, first iteration of a block (DESIGN section 4): the fp32 Jacobi residual
// r_i = g_i q_i + sum_k w_ik phi_nbr - phi_i of the fp32 state. r is kept in fp32 for the block's
// correction sweeps and is also their first iterate (delta_1 = r: one Jacobi step from delta = 0).
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D phi;
layout(set = 0, binding = 1, rgba32f) uniform writeonly image2D residual;
layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D delta;
layout(set = 0, binding = 3, rgba16f) uniform readonly image2D q;
layout(set = 0, binding = 4, rgba32ui) uniform readonly uimage2D connectivity;
layout(set = 0, binding = 5, rgba32f) uniform readonly image2D weight_r;
layout(set = 0, binding = 6, rgba32f) uniform readonly image2D weight_g;
layout(set = 0, binding = 7, rgba32f) uniform readonly image2D weight_b;

#include "graph_common.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p)) {
        return;
    }
    uvec4 nb = imageLoad(connectivity, p);
    vec4 wr = imageLoad(weight_r, p);
    vec4 wg = imageLoad(weight_g, p);
    vec4 wb = imageLoad(weight_b, p);
    bool surface = is_surface_row(p);
    vec3 acc = surface ? vec3(wr[1], wg[1], wb[1]) * imageLoad(q, p).rgb : vec3(0.0);
    for (int k = 0; k < (surface ? 1 : 4); ++k) {
        acc += vec3(wr[k], wg[k], wb[k]) * imageLoad(phi, texel_of(nb[k])).rgb;
    }
    vec3 r = acc - imageLoad(phi, p).rgb;
    imageStore(residual, p, vec4(r, 0.0));
    imageStore(delta, p, vec4(r, 0.0));
}
