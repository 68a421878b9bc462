#version 460
#extension GL_GOOGLE_include_directive : require
// r = f - K x on one level (CSR rows, the diagonal apart).
// Entries below HALF_ENTRIES (the coarse levels' under `--coarse-storage f16`, which come first)
// are RGB fp16 in `values16` (two uints), relative to the row's scale in diag.a; the others are
// RGB f32 in `values`, three floats from 3 (e - HALF_ENTRIES) (`solver::gpu::multigrid`,
// `pack_operators`). The finest level under GRAPH_FINEST: K from the cascade's graph textures
// (graph_operator.glsl), its rows not stored.
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint HALF_ENTRIES = 0u;

#include "common.glsl"

layout(set = 0, binding = 0, std430) readonly buffer Xs { float v[]; } x;
layout(set = 0, binding = 1, std430) readonly buffer Fs { float v[]; } f;
layout(set = 0, binding = 2, std430) writeonly buffer Rs { float v[]; } r;
layout(set = 0, binding = 3, std430) readonly buffer RowStart { uint v[]; } row_start;
layout(set = 0, binding = 4, std430) readonly buffer Cols { uint v[]; } cols;
layout(set = 0, binding = 5, std430) readonly buffer Values { float v[]; } values;
layout(set = 0, binding = 6, std430) readonly buffer Diag { vec4 v[]; } diag;
layout(set = 0, binding = 7, std430) readonly buffer Values16 { uvec2 v[]; } values16;

#include "graph_operator.glsl"

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint i = pc.offset + gl_GlobalInvocationID.x;
    vec4 d = diag.v[i];
    if (reads_graph(pc.offset)) {
        SET_RGB(r, i, RGB(f, i) - graph_apply(gl_GlobalInvocationID.x, i, d.rgb));
        return;
    }
    uint first = row_start.v[i];
    uint end = row_start.v[i + 1u];
    vec3 acc = d.rgb * RGB(x, i);
    if (first < HALF_ENTRIES) {
        vec3 scaled = vec3(0.0);
        for (uint e = first; e < end; ++e) {
            uvec2 h = values16.v[e];
            vec3 v = vec3(unpackHalf2x16(h.x), unpackHalf2x16(h.y).x);
            scaled += v * RGB(x, cols.v[e]);
        }
        acc += d.a * scaled;
    } else {
        for (uint e = first; e < end; ++e) {
            uint j = 3u * (e - HALF_ENTRIES);
            acc += vec3(values.v[j], values.v[j + 1u], values.v[j + 2u]) * RGB(x, cols.v[e]);
        }
    }
    SET_RGB(r, i, RGB(f, i) - acc);
}
