#version 460
#extension GL_GOOGLE_include_directive : require
// r = f - K x on one level (CSR rows, the diagonal apart).
// Entries below HALF_ENTRIES (the coarse levels' under `--coarse-storage f16`, which come first)
// are RGB fp16 in `values16` (two uints), relative to the row's scale in diag.a; the others are
// RGB f32 in `values`, three floats from 3 (e - HALF_ENTRIES) (`solver::gpu::multigrid`,
// `pack_operators`). The finest level under GRAPH_FINEST: K from the cascade's graph textures
// (graph_operator.glsl), its rows not stored.
// TEXEL_READS: every read-only input through a uniform texel buffer over the same buffer (the
// `*_t` bindings) instead of the storage buffer: the same values, the same arithmetic; on lavapipe
// a storage-buffer read at a per-invocation address is a loop over the lanes with a branch per
// lane and component, a texel fetch one gather (benches/RESULTS.md "Fewer bytes per finest pass
// (wave 11)"; `TRANSLUCENT_MULTIGRID_READS`, `solver::gpu::multigrid::texels`).
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint HALF_ENTRIES = 0u;
layout(constant_id = 9) const bool TEXEL_READS = false;

#include "common.glsl"

layout(set = 0, binding = 0, std430) readonly buffer Xs { float v[]; } x;
layout(set = 0, binding = 1, std430) readonly buffer Fs { float v[]; } f;
layout(set = 0, binding = 2, std430) writeonly buffer Rs { float v[]; } r;
layout(set = 0, binding = 3, std430) readonly buffer RowStart { uint v[]; } row_start;
layout(set = 0, binding = 4, std430) readonly buffer Cols { uint v[]; } cols;
layout(set = 0, binding = 5, std430) readonly buffer Values { float v[]; } values;
layout(set = 0, binding = 6, std430) readonly buffer Diag { vec4 v[]; } diag;
layout(set = 0, binding = 7, std430) readonly buffer Values16 { uvec2 v[]; } values16;
layout(set = 0, binding = 8) uniform samplerBuffer x_t;
layout(set = 0, binding = 9) uniform samplerBuffer f_t;
layout(set = 0, binding = 10) uniform samplerBuffer diag_t;
layout(set = 0, binding = 11) uniform usamplerBuffer row_start_t;
layout(set = 0, binding = 12) uniform usamplerBuffer cols_t;
layout(set = 0, binding = 13) uniform samplerBuffer values_t;
layout(set = 0, binding = 14) uniform usamplerBuffer values16_t;
layout(set = 0, binding = 15) uniform usamplerBuffer node_texel_t;
layout(set = 0, binding = 16) uniform usamplerBuffer texel_node_t;

#define READ_X(i) (TEXEL_READS ? RGB_TEXELS(x_t, i) : RGB(x, i))
#define READ_U(buf, i) (TEXEL_READS ? texelFetch(buf##_t, int(i)).x : buf.v[i])
#define GRAPH_NODE_TEXEL(node) READ_U(node_texel, node)
#define GRAPH_TEXEL_NODE(texel) READ_U(texel_node, texel)
#define GRAPH_X(i) READ_X(i)
#include "graph_operator.glsl"

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint i = pc.offset + gl_GlobalInvocationID.x;
    vec4 d = TEXEL_READS ? texelFetch(diag_t, int(i)) : diag.v[i];
    vec3 fi = TEXEL_READS ? RGB_TEXELS(f_t, i) : RGB(f, i);
    if (reads_graph(pc.offset)) {
        SET_RGB(r, i, fi - graph_apply(gl_GlobalInvocationID.x, i, d.rgb));
        return;
    }
    uint first = READ_U(row_start, i);
    uint end = READ_U(row_start, i + 1u);
    vec3 acc = d.rgb * READ_X(i);
    if (first < HALF_ENTRIES) {
        vec3 scaled = vec3(0.0);
        for (uint e = first; e < end; ++e) {
            uvec2 h = TEXEL_READS ? texelFetch(values16_t, int(e)).xy : values16.v[e];
            vec3 v = vec3(unpackHalf2x16(h.x), unpackHalf2x16(h.y).x);
            scaled += v * READ_X(HALF_COLUMN(h, READ_U(cols, e)));
        }
        acc += d.a * scaled;
    } else {
        for (uint e = first; e < end; ++e) {
            uint j = 3u * (e - HALF_ENTRIES);
            vec3 v = TEXEL_READS ? vec3(texelFetch(values_t, int(j)).x,
                                        texelFetch(values_t, int(j + 1u)).x,
                                        texelFetch(values_t, int(j + 2u)).x)
                                 : vec3(values.v[j], values.v[j + 1u], values.v[j + 2u]);
            acc += v * READ_X(READ_U(cols, e));
        }
    }
    SET_RGB(r, i, fi - acc);
}
