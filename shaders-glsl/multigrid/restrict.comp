#version 460
#extension GL_GOOGLE_include_directive : require
// Restriction P^T (the transpose of the Shepard prolongation, by coarse rows: a gather, no
// atomics; each entry the slot of a fine node's link, which holds the weight):
// f_c = sum_fine w r_fine (mode 1: of the fine right-hand side, full multigrid), and the coarse
// correction starts at zero.
layout(local_size_x = 64) in;

#include "common.glsl"

layout(set = 0, binding = 0, std430) writeonly buffer Xs { float v[]; } x;
layout(set = 0, binding = 1, std430) buffer Fs { float v[]; } f;
layout(set = 0, binding = 2, std430) readonly buffer Rs { float v[]; } r;
layout(set = 0, binding = 3, std430) readonly buffer TStart { uint v[]; } t_start;
layout(set = 0, binding = 4, std430) readonly buffer TLink { uint v[]; } t_link;
// The prolongation's links (prolong.comp): slot 8 i + k of fine node i.
layout(constant_id = 1) const uint PACKED_LINKS = 1u;
layout(set = 0, binding = 5, std430) readonly buffer Links { uint v[]; } links;
layout(set = 0, binding = 6, std430) readonly buffer LinkWeights { float v[]; } link_weights;

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint c = pc.offset + gl_GlobalInvocationID.x;
    vec3 acc = vec3(0.0);
    for (uint e = t_start.v[c]; e < t_start.v[c + 1u]; ++e) {
        uint slot = t_link.v[e];
        uint i = slot / 8u;
        float w = PACKED_LINKS != 0u ? LINK_WEIGHT(links.v[slot]) : link_weights.v[slot];
        acc += w * (pc.mode == 1u ? RGB(f, i) : RGB(r, i));
    }
    SET_RGB(f, c, acc);
    SET_RGB(x, c, vec3(0.0));
}
