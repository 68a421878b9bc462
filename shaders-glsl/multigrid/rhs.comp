#version 460
#extension GL_GOOGLE_include_directive : require
// The finest level's right-hand side from the gather's q image: f = S b = rhs_coef * q (row scale
// times q_gain on surface rows, 0 on inner rows), times the exposure like q. Mode 1 (cold start):
// x = 0 too; mode 0 (warm start): a non-finite x (a diverged last solve) restarts from 0.
layout(local_size_x = 64) in;

#include "common.glsl"

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D q;
layout(set = 0, binding = 1, std430) writeonly buffer Fs { float v[]; } f;
layout(set = 0, binding = 2, std430) buffer Xs { float v[]; } x;
layout(set = 0, binding = 3, std430) readonly buffer NodeTexel { uint v[]; } node_texel;
layout(set = 0, binding = 4, std430) readonly buffer RhsCoef { float v[]; } rhs_coef;

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint node = gl_GlobalInvocationID.x;
    uint i = pc.offset + node;
    float coef = rhs_coef.v[node];
    vec3 value = vec3(0.0);
    if (coef != 0.0) {
        uint t = node_texel.v[node];
        value = coef * imageLoad(q, ivec2(int(t % pc.width), int(t / pc.width))).rgb;
    }
    SET_RGB(f, i, value);
    if (pc.mode == 1u) {
        SET_RGB(x, i, vec3(0.0));
    } else {
        vec3 xi = RGB(x, i);
        if (any(isnan(xi)) || any(isinf(xi))) {
            SET_RGB(x, i, vec3(0.0));
        }
    }
}
