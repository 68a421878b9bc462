// Transmitted irradiance E T_i of any node of the face-cluster hierarchy: leaves (triangles) are
// read from the method's input buffer, clusters from the pulled buffer (internal node id - leaf count).
#ifndef CLUSTER_IRRADIANCE_GLSL
#define CLUSTER_IRRADIANCE_GLSL

layout(set = 0, binding = 0, std430) readonly buffer LeafIrradiance { vec4 values[]; } leaf_irradiance;
layout(set = 0, binding = 1, std430) buffer NodeIrradiance { vec4 values[]; } node_irradiance;

vec3 irradiance_of(uint node, uint leaf_count) {
    return node < leaf_count ? leaf_irradiance.values[node].rgb
                             : node_irradiance.values[node - leaf_count].rgb;
}

#endif
