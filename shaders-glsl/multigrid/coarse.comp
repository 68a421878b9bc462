#version 460
#extension GL_GOOGLE_include_directive : require
// The coarsest level's solve in one dispatch of one workgroup (benches/RESULTS.md "Time per work
// unit (wave 9)"): the Chebyshev polynomial of `pc.mode` steps on the level's Lanczos interval,
// from x = 0, every step what `residual.comp` (r = f - K x, the CSR rows) and `smooth.comp` (the
// block Jacobi step d = alpha d + beta B^-1 r, x += d) do in two dispatches each, here separated by
// workgroup barriers instead. On lavapipe a dispatch and its pipeline barrier cost more than a
// coarsest sweep (a thousand nodes), so one workgroup looping beats 2 steps - 1 dispatches.
// The coefficients follow the recurrence of `solver::multigrid::chebyshev_coefficients` on the
// interval [pc.alpha, pc.beta] per channel (in f32 here, f64 there). Stops at once when the
// cycles stopped (`control.state`), as the indirect dispatches it replaces would.
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint HALF_ENTRIES = 0u;

#include "common.glsl"

layout(set = 0, binding = 0, std430) buffer Xs { float v[]; } x;
layout(set = 0, binding = 1, std430) buffer Ds { uint v[]; } d;
layout(set = 0, binding = 2, std430) buffer Rs { float v[]; } r;
layout(set = 0, binding = 3, std430) readonly buffer Fs { float v[]; } f;
layout(set = 0, binding = 4, std430) readonly buffer RowStart { uint v[]; } row_start;
layout(set = 0, binding = 5, std430) readonly buffer Cols { uint v[]; } cols;
layout(set = 0, binding = 6, std430) readonly buffer Values { float v[]; } values;
layout(set = 0, binding = 7, std430) readonly buffer Diag { vec4 v[]; } diag;
layout(set = 0, binding = 8, std430) readonly buffer Values16 { uvec2 v[]; } values16;
layout(set = 0, binding = 9, std430) readonly buffer Partner { uint v[]; } partner;
layout(set = 0, binding = 10, std430) readonly buffer PartnerValue { float v[]; } partner_value;
layout(set = 0, binding = 11, std430) readonly buffer Control { MultigridControl c; } control;

// r = f - K x at node i (residual.comp's CSR row).
vec3 row_residual(uint i) {
    vec4 di = diag.v[i];
    uint first = row_start.v[i];
    uint end = row_start.v[i + 1u];
    vec3 acc = di.rgb * RGB(x, i);
    if (first < HALF_ENTRIES) {
        vec3 scaled = vec3(0.0);
        for (uint e = first; e < end; ++e) {
            uvec2 h = values16.v[e];
            vec3 v = vec3(unpackHalf2x16(h.x), unpackHalf2x16(h.y).x);
            scaled += v * RGB(x, HALF_COLUMN(h, cols.v[e]));
        }
        acc += di.a * scaled;
    } else {
        for (uint e = first; e < end; ++e) {
            uint j = 3u * (e - HALF_ENTRIES);
            acc += vec3(values.v[j], values.v[j + 1u], values.v[j + 2u]) * RGB(x, cols.v[e]);
        }
    }
    return RGB(f, i) - acc;
}

// B^-1 of the residual at node i (smooth.comp's block); `first`: the residual is f.
vec3 block_jacobi(uint i, bool first) {
    vec3 a = diag.v[i].rgb;
    vec3 ri = first ? RGB(f, i) : RGB(r, i);
    uint p = partner.v[i];
    if (p == NO_NODE) {
        return ri / a;
    }
    vec3 b = RGB(partner_value, i);
    vec3 dp = diag.v[p].rgb;
    vec3 rp = first ? RGB(f, p) : RGB(r, p);
    return (dp * ri - b * rp) / (a * dp - b * b);
}

void main() {
    if (control.c.state != 0u) {
        return;
    }
    uint lid = gl_LocalInvocationID.x;
    vec3 lo = pc.alpha.rgb;
    vec3 hi = pc.beta.rgb;
    vec3 theta = 0.5 * (hi + lo);
    vec3 delta = 0.5 * (hi - lo);
    vec3 sigma = theta / delta;
    // Step 0 from x = 0: d = B^-1 f / theta.
    vec3 rho = 1.0 / sigma;
    for (uint k = lid; k < pc.count; k += 64u) {
        uint i = pc.offset + k;
        vec3 di = block_jacobi(i, true) / theta;
        STORE_UPDATE(d, i, di);
        SET_RGB(x, i, di);
    }
    for (uint step = 1u; step < pc.mode; ++step) {
        vec3 next = 1.0 / (2.0 * sigma - rho);
        vec3 alpha = next * rho;
        vec3 beta = 2.0 * next / delta;
        rho = next;
        // why: the residual reads x of every node the last step wrote (buffer RAW within the
        // workgroup).
        memoryBarrierBuffer();
        barrier();
        for (uint k = lid; k < pc.count; k += 64u) {
            uint i = pc.offset + k;
            SET_RGB(r, i, row_residual(i));
        }
        // why: the step reads the residual of a node's partner and overwrites x the residual
        // pass read (RAW, WAR within the workgroup).
        memoryBarrierBuffer();
        barrier();
        for (uint k = lid; k < pc.count; k += 64u) {
            uint i = pc.offset + k;
            vec3 di = alpha * LOAD_UPDATE(d, i) + beta * block_jacobi(i, false);
            STORE_UPDATE(d, i, di);
            SET_RGB(x, i, RGB(x, i) + di);
        }
    }
}
