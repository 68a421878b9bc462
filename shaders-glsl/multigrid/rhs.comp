#version 460
#extension GL_GOOGLE_include_directive : require
// The finest level's right-hand side from the gather's q image: f = S b = rhs_coef * q (row scale
// times q_gain on surface rows, 0 on inner rows), times the exposure like q. Mode 1 (cold start):
// x = 0 too; mode 0 (warm start): a non-finite x (a diverged last solve) restarts from 0; mode
// 2 + k (warm start extrapolated, k + 1 earlier solutions kept in x_history, node-major per slot):
// x = alpha.x x + alpha.y x_history[0] + alpha.z x_history[1] (Newton's backward differences:
// the last solution, the linear or the quadratic extrapolation), then the slots shift by one
// (the oldest drops out, the last solution enters slot 0); a non-finite result keeps the last
// solution.
layout(local_size_x = 64) in;

#include "common.glsl"

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D q;
layout(set = 0, binding = 1, std430) writeonly buffer Fs { float v[]; } f;
layout(set = 0, binding = 2, std430) buffer Xs { float v[]; } x;
layout(set = 0, binding = 3, std430) readonly buffer NodeTexel { uint v[]; } node_texel;
layout(set = 0, binding = 4, std430) readonly buffer RhsCoef { float v[]; } rhs_coef;
layout(set = 0, binding = 5, std430) buffer XHistory { float v[]; } x_history;

bool finite(vec3 v) {
    return !(any(isnan(v)) || any(isinf(v)));
}

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
        return;
    }
    vec3 xi = RGB(x, i);
    if (!finite(xi)) {
        xi = vec3(0.0);
        SET_RGB(x, i, vec3(0.0));
    }
    if (pc.mode >= 2u) {
        uint slots = pc.mode - 1u;
        vec3 h0 = RGB(x_history, node);
        vec3 h1 = slots > 1u ? RGB(x_history, pc.count + node) : vec3(0.0);
        vec3 next = pc.alpha.x * xi + pc.alpha.y * h0 + pc.alpha.z * h1;
        if (slots > 1u) {
            SET_RGB(x_history, pc.count + node, h0);
        }
        SET_RGB(x_history, node, xi);
        SET_RGB(x, i, finite(next) ? next : xi);
    }
}
