#version 460
// Dipole method, push (Mertens et al. 2003, section 3.2): what a cluster received goes to every
// triangle below it. Dispatched per merge round top-down, then over the leaves: each node adds its
// parent's accumulated exitance to its own.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0, std430) buffer NodeExitance { vec4 values[]; } node_exitance;
layout(set = 0, binding = 1, std430) readonly buffer NodeParent { uint values[]; } node_parent;

layout(push_constant) uniform PushDownPush {
    uint first_node;
    uint count;
} pc;

const uint NO_NODE = 0xffffffffu;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint n = pc.first_node + i;
    uint p = node_parent.values[n];
    if (p != NO_NODE) {
        node_exitance.values[n] += node_exitance.values[p];
    }
}
