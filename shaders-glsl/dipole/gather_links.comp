#version 460
// Dipole method, gather (Mertens et al. 2003, Eq. 6 along links): every node R of the hierarchy
// sums F(E, c_R) E_E over its links (CSR by receiver), per colour channel; F is the form factor
// (Eq. 7) computed on the CPU when the links were made.
layout(local_size_x = 64) in;

#include "cluster_irradiance.glsl"

struct Link {
    vec3 form_factor;
    uint source;
};
layout(set = 0, binding = 2, std430) readonly buffer ReceiverOffsets { uint values[]; } receiver_offsets;
layout(set = 0, binding = 3, std430) readonly buffer Links { Link values[]; } links;
layout(set = 0, binding = 4, std430) writeonly buffer NodeExitance { vec4 values[]; } node_exitance;

layout(push_constant) uniform GatherPush {
    uint node_count;
    uint leaf_count;
} pc;

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= pc.node_count) {
        return;
    }
    vec3 b = vec3(0.0);
    uint end = receiver_offsets.values[r + 1u];
    for (uint k = receiver_offsets.values[r]; k < end; ++k) {
        Link l = links.values[k];
        b += l.form_factor * irradiance_of(l.source, pc.leaf_count);
    }
    node_exitance.values[r] = vec4(b, 0.0);
}
