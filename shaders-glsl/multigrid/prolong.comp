#version 460
#extension GL_GOOGLE_include_directive : require
// Prolongation (paper Eq. 10 applied to a correction): x_fine += sum_k w_k x_coarse[link_k]
// (mode 1: x_fine = ..., full multigrid's start of a level; mode 2: r_fine = x_fine + ..., where a
// fused post-smoothing run of an odd count of steps starts, `relax.comp`).
layout(local_size_x = 64) in;

#include "common.glsl"

layout(set = 0, binding = 0, std430) buffer Xs { float v[]; } x;
// 8 link slots per node (slot 8 i + k); PACKED_LINKS: `coarse node << 8 | weight in 1/255`
// (LinkStorage::Packed, link_weights unused), else the coarse node and link_weights' f32.
layout(constant_id = 1) const uint PACKED_LINKS = 1u;
layout(set = 0, binding = 1, std430) readonly buffer Links { uint v[]; } links;
layout(set = 0, binding = 2, std430) readonly buffer LinkWeights { float v[]; } link_weights;
layout(set = 0, binding = 3, std430) writeonly buffer Rs { float v[]; } r;

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint i = pc.offset + gl_GlobalInvocationID.x;
    vec3 acc = pc.mode == 1u ? vec3(0.0) : RGB(x, i);
    for (uint k = 0u; k < 8u; ++k) {
        uint slot = 8u * i + k;
        uint link = links.v[slot];
        if (link != NO_NODE) {
            if (PACKED_LINKS != 0u) {
                acc += LINK_WEIGHT(link) * RGB(x, link >> 8);
            } else {
                acc += link_weights.v[slot] * RGB(x, link);
            }
        }
    }
    if (pc.mode == 2u) {
        SET_RGB(r, i, acc);
    } else {
        SET_RGB(x, i, acc);
    }
}
