#version 460
// Dipole method, pull (Mertens et al. 2003, section 3.2): each cluster of one merge round gets the
// area-weighted average of its two children's transmitted irradiance. Dispatched once per round,
// bottom-up; children always belong to earlier rounds (or are leaves).
layout(local_size_x = 64) in;

#include "cluster_irradiance.glsl"

// Children (node ids) and their area shares, per internal node.
struct ClusterChildren {
    uvec2 children;
    vec2 weights;
};
layout(set = 0, binding = 2, std430) readonly buffer Clusters { ClusterChildren nodes[]; } clusters;

layout(push_constant) uniform PullPush {
    uint first_node; // absolute node id of the round's first cluster (>= leaf_count)
    uint count;
    uint leaf_count;
    uint pad;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    uint internal = pc.first_node + i - pc.leaf_count;
    ClusterChildren c = clusters.nodes[internal];
    vec3 e = c.weights.x * irradiance_of(c.children.x, pc.leaf_count)
        + c.weights.y * irradiance_of(c.children.y, pc.leaf_count);
    node_irradiance.values[internal] = vec4(e, 0.0);
}
