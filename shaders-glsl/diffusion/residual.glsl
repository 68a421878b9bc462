// Mixed precision, first iteration of a block (DESIGN section 4): the fp32 Jacobi residual
// r_i = g_i q_i + sum_k w_ik phi_nbr - phi_i of the fp32 state. r is kept in fp32 for the block's
// correction sweeps and is also their first iterate (delta_1 = r: one Jacobi step from delta = 0).
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D phi;
layout(set = 0, binding = 1, rgba32f) uniform writeonly image2D residual;
layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D delta;
layout(set = 0, binding = 3, rgba16f) uniform readonly image2D q;
layout(set = 0, binding = 4, rgba32ui) uniform readonly uimage2D connectivity;

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
    vec3 acc = surface ? gain * imageLoad(q, p).rgb : vec3(0.0);
    ADD_NEIGHBOUR_SUM(acc, phi, nb, w, surface);
    vec3 r = acc - imageLoad(phi, p).rgb;
    imageStore(residual, p, vec4(r, 0.0));
    imageStore(delta, p, vec4(r, 0.0));
}
