// One pure Jacobi iteration of every node of a level (paper Eqs. 8 and 9; DESIGN section 2's fv
// form and corrected 4q/(1 - F_dr)): phi_i <- g_i q_i + sum_k w_ik phi_nbr(i,k), surface and inner
// nodes in the same dispatch (surface rows only have a non-zero source gain g and one neighbour).
// Included with STATE_FORMAT set to the ping-pong format.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, STATE_FORMAT) uniform readonly image2D src;
layout(set = 0, binding = 1, STATE_FORMAT) uniform writeonly image2D dst;
layout(set = 0, binding = 2, rgba16f) uniform readonly image2D q;
layout(set = 0, binding = 3, rgba32ui) uniform readonly uimage2D connectivity;

#include "graph_common.glsl"
#include "graph_weights.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p)) {
        return;
    }
    uvec4 nb = imageLoad(connectivity, p);
    bool surface = is_surface_row(p);
    vec3 w[4];
    vec3 gain;
    node_weights(p, nb, surface, w, gain);
    // Eq. 9's source term on surface rows (zero weights on padding).
    vec3 acc = surface ? gain * imageLoad(q, p).rgb : vec3(0.0);
    ADD_NEIGHBOUR_SUM(acc, src, nb, w, surface);
    imageStore(dst, p, vec4(acc, 0.0));
}
