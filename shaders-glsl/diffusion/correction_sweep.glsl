// Mixed precision inner sweep (DESIGN section 4): Jacobi on the correction, A delta = r, in fp16
// ping-pong: delta_i <- r_i + sum_k w_ik delta_nbr. The correction shrinks as phi converges, so the
// fp16 rounding is relative to the correction, not to phi: this is what removes the fp16 stall.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D src;
layout(set = 0, binding = 1, rgba16f) uniform writeonly image2D dst;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D residual;
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
    vec3 acc = imageLoad(residual, p).rgb;
    ADD_NEIGHBOUR_SUM(acc, src, nb, w, surface);
    imageStore(dst, p, vec4(acc, 0.0));
}
