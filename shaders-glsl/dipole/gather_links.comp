#version 460
// Dipole method, gather (Mertens et al. 2003, Eq. 6 along links): every node R of the hierarchy
// sums F(E, c_R) E_E over its links (CSR by receiver), per colour channel; F is the form factor
// (Eq. 7) computed on the CPU when the links were made.
//
// The links are one buffer bound as up to four windows of `link_window` links each (binding
// k / link_window holds link k): one binding may not exceed the device's maxStorageBufferRange
// (128 MiB on lavapipe, 8M links), and without descriptor indexing the window is chosen by a
// branch over the separate bindings.
layout(local_size_x = 64) in;

#include "cluster_irradiance.glsl"

struct Link {
    vec3 form_factor;
    uint source;
};
layout(set = 0, binding = 2, std430) readonly buffer ReceiverOffsets { uint values[]; } receiver_offsets;
layout(set = 0, binding = 3, std430) readonly buffer Links0 { Link values[]; } links_0;
layout(set = 0, binding = 4, std430) writeonly buffer NodeExitance { vec4 values[]; } node_exitance;
layout(set = 0, binding = 5, std430) readonly buffer Links1 { Link values[]; } links_1;
layout(set = 0, binding = 6, std430) readonly buffer Links2 { Link values[]; } links_2;
layout(set = 0, binding = 7, std430) readonly buffer Links3 { Link values[]; } links_3;

layout(push_constant) uniform GatherPush {
    uint node_count;
    uint leaf_count;
    uint link_window;
} pc;

// Adds the links [first, last) of one window binding (indices inside the window).
#define GATHER_WINDOW(binding)                                                  \
    for (uint i = first; i < last; ++i) {                                       \
        Link l = binding.values[i];                                             \
        b += l.form_factor * irradiance_of(l.source, pc.leaf_count);            \
    }

void main() {
    uint r = gl_GlobalInvocationID.x;
    if (r >= pc.node_count) {
        return;
    }
    vec3 b = vec3(0.0);
    uint k = receiver_offsets.values[r];
    uint end = receiver_offsets.values[r + 1u];
    // A receiver's links are contiguous: split them where they cross a window boundary, so the
    // inner loops neither divide nor branch per link.
    while (k < end) {
        uint window = k / pc.link_window;
        uint base = window * pc.link_window;
        uint first = k - base;
        uint last = min(end - base, pc.link_window);
        if (window == 0u) {
            GATHER_WINDOW(links_0)
        } else if (window == 1u) {
            GATHER_WINDOW(links_1)
        } else if (window == 2u) {
            GATHER_WINDOW(links_2)
        } else {
            GATHER_WINDOW(links_3)
        }
        k = base + last;
    }
    node_exitance.values[r] = vec4(b, 0.0);
}
