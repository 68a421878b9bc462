#version 460
#extension GL_GOOGLE_include_directive : require
// One Chebyshev (or damped Jacobi: alpha = 0) step on one level, from the residual r = f - K x:
// d = alpha d + beta B^-1 r, x += d. B is the diagonal, or the 2x2 block of a surface node and its
// cell (`partner`). No reduction: alpha and beta are constants per step (push). Mode 1: the first
// step from x = 0, whose residual is f itself (no residual pass before it).
// TEXEL_READS: the read-only inputs through uniform texel buffers over the same buffers (the `*_t`
// bindings), as residual.comp; x and d (read and written) stay storage buffers.
layout(local_size_x = 64) in;
layout(constant_id = 9) const bool TEXEL_READS = false;

#include "common.glsl"

layout(set = 0, binding = 0, std430) buffer Xs { float v[]; } x;
layout(set = 0, binding = 1, std430) buffer Ds { uint v[]; } d;
layout(set = 0, binding = 2, std430) readonly buffer Rs { float v[]; } r;
layout(set = 0, binding = 3, std430) readonly buffer Diag { vec4 v[]; } diag;
layout(set = 0, binding = 4, std430) readonly buffer Partner { uint v[]; } partner;
layout(set = 0, binding = 5, std430) readonly buffer PartnerValue { float v[]; } partner_value;
layout(set = 0, binding = 6, std430) readonly buffer Fs { float v[]; } f;
layout(set = 0, binding = 7) uniform samplerBuffer r_t;
layout(set = 0, binding = 8) uniform samplerBuffer diag_t;
layout(set = 0, binding = 9) uniform usamplerBuffer partner_t;
layout(set = 0, binding = 10) uniform samplerBuffer partner_value_t;
layout(set = 0, binding = 11) uniform samplerBuffer f_t;

vec3 residual(uint j) {
    if (TEXEL_READS) {
        return pc.mode == 1u ? RGB_TEXELS(f_t, j) : RGB_TEXELS(r_t, j);
    }
    return pc.mode == 1u ? RGB(f, j) : RGB(r, j);
}

vec3 diagonal(uint j) {
    return TEXEL_READS ? texelFetch(diag_t, int(j)).rgb : diag.v[j].rgb;
}

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint i = pc.offset + gl_GlobalInvocationID.x;
    vec3 a = diagonal(i);
    vec3 ri = residual(i);
    vec3 z;
    uint p = TEXEL_READS ? texelFetch(partner_t, int(i)).x : partner.v[i];
    if (p != NO_NODE) {
        vec3 b = TEXEL_READS ? RGB_TEXELS(partner_value_t, i) : RGB(partner_value, i);
        vec3 dp = diagonal(p);
        z = (dp * ri - b * residual(p)) / (a * dp - b * b);
    } else {
        z = ri / a;
    }
    // alpha = 0 on a first step: d may hold the last visit's values.
    vec3 di = pc.beta.rgb * z;
    if (pc.alpha != vec4(0.0)) {
        di += pc.alpha.rgb * LOAD_UPDATE(d, i);
    }
    STORE_UPDATE(d, i, di);
    // Mode 1 starts from x = 0: x is not read (the CG's fused start leaves the iterate there).
    SET_RGB(x, i, pc.mode == 1u ? di : RGB(x, i) + di);
}
