// One pure Jacobi iteration of every node of a level (paper Eqs. 8 and 9; DESIGN section 2's fv
// form and corrected 4q/(1 - F_dr)): phi_i <- g_i q_i + sum_k w_ik phi_nbr(i,k), surface and inner
// nodes in the same dispatch (surface rows only have a non-zero source gain g and one neighbour).
// Included with STATE_FORMAT set to the ping-pong format.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, STATE_FORMAT) uniform readonly image2D src;
layout(set = 0, binding = 1, STATE_FORMAT) uniform writeonly image2D dst;
layout(set = 0, binding = 2, rgba16f) uniform readonly image2D q;
layout(set = 0, binding = 3, rgba32ui) uniform readonly uimage2D connectivity;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D weight_r;
layout(set = 0, binding = 5, rgba32f) uniform readonly image2D weight_g;
layout(set = 0, binding = 6, rgba32f) uniform readonly image2D weight_b;

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
    // Eq. 9's source term on surface rows (zero weights on padding).
    bool surface = is_surface_row(p);
    vec3 acc = surface ? vec3(wr[1], wg[1], wb[1]) * imageLoad(q, p).rgb : vec3(0.0);
    for (int k = 0; k < (surface ? 1 : 4); ++k) {
        vec3 phi_j = imageLoad(src, texel_of(nb[k])).rgb;
        acc += vec3(wr[k], wg[k], wb[k]) * phi_j;
    }
    imageStore(dst, p, vec4(acc, 0.0));
}
