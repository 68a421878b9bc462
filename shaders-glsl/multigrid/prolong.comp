#version 460
#extension GL_GOOGLE_include_directive : require
// Prolongation (paper Eq. 10 applied to a correction): x_fine += sum_k w_k x_coarse[link_k]
// (mode 1: x_fine = ..., full multigrid's start of a level).
layout(local_size_x = 64) in;

#include "common.glsl"

layout(set = 0, binding = 0, std430) buffer Xs { vec4 v[]; } x;
layout(set = 0, binding = 1, std430) readonly buffer Links { uvec4 v[]; } links;
layout(set = 0, binding = 2, std430) readonly buffer LinkWeights { vec4 v[]; } link_weights;

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint i = pc.offset + gl_GlobalInvocationID.x;
    vec3 acc = pc.mode == 1u ? vec3(0.0) : x.v[i].rgb;
    for (uint h = 0u; h < 2u; ++h) {
        uvec4 l = links.v[2u * i + h];
        vec4 w = link_weights.v[2u * i + h];
        for (int k = 0; k < 4; ++k) {
            if (l[k] != NO_NODE) {
                acc += w[k] * x.v[l[k]].rgb;
            }
        }
    }
    x.v[i] = vec4(acc, 0.0);
}
