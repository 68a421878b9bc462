#version 460
#extension GL_GOOGLE_include_directive : require
// One Chebyshev step in one pass, an option (TRANSLUCENT_MULTIGRID_RELAX=fused: the finest level,
// =all: every level above the coarsest; measured slower than the two passes on lavapipe:
// benches/RESULTS.md "Cheaper multigrid passes (wave 10)"): what `residual.comp` then
// `smooth.comp` do, r = f - K x and d = alpha d + beta B^-1 r, x += d, with the residual formed
// where it is used instead of stored. The block of a surface node and its cell needs both rows:
// the block's surface node (the higher index: surface nodes come after the inner ones) forms the
// partner's row too and updates both nodes; its cell returns after its own row. The surface nodes
// are contiguous, so on SIMD hardware (lavapipe's 8 lanes) a batch of them takes the two-row path
// together and a batch of inner nodes the one-row path: few batches run both. A node whose
// partner is not paired back with it (a cell with several surface faces keeps one) forms its own
// row and its partner's. Jacobi reads the old x of the neighbours while the new x is written, so
// the pass reads `x` and writes `x_out`: the recorder binds the level's x and r buffers in both
// orders and alternates them, x -> r -> x (r is free during a smoothing run: the next residual
// overwrites it); a run from r starts where the prolongation wrote x + P e (`prolong.comp` mode 2).
layout(local_size_x = 64) in;
layout(constant_id = 0) const uint HALF_ENTRIES = 0u;

#include "common.glsl"

layout(set = 0, binding = 0, std430) readonly buffer Xs { float v[]; } x;
layout(set = 0, binding = 1, std430) writeonly buffer XOut { float v[]; } x_out;
layout(set = 0, binding = 2, std430) buffer Ds { uint v[]; } d;
layout(set = 0, binding = 3, std430) readonly buffer Fs { float v[]; } f;
layout(set = 0, binding = 4, std430) readonly buffer RowStart { uint v[]; } row_start;
layout(set = 0, binding = 5, std430) readonly buffer Cols { uint v[]; } cols;
layout(set = 0, binding = 6, std430) readonly buffer Values { float v[]; } values;
layout(set = 0, binding = 7, std430) readonly buffer Diag { vec4 v[]; } diag;
layout(set = 0, binding = 8, std430) readonly buffer Values16 { uvec2 v[]; } values16;
layout(set = 0, binding = 9, std430) readonly buffer Partner { uint v[]; } partner;
layout(set = 0, binding = 10, std430) readonly buffer PartnerValue { float v[]; } partner_value;

#include "graph_operator.glsl"

// r = f - K x at node i of the level at pc.offset (residual.comp's row).
vec3 row_residual(uint i) {
    vec4 di = diag.v[i];
    if (reads_graph(pc.offset)) {
        return RGB(f, i) - graph_apply(i - pc.offset, i, di.rgb);
    }
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

// The step at node i from its block's solve z: d = alpha d + beta z, x_out = x + d.
void chebyshev_step(uint i, vec3 z) {
    // alpha = 0 on a run's first step: d may hold the last visit's values (not read).
    vec3 di = pc.beta.rgb * z;
    if (pc.alpha != vec4(0.0)) {
        di += pc.alpha.rgb * LOAD_UPDATE(d, i);
    }
    STORE_UPDATE(d, i, di);
    SET_RGB(x_out, i, RGB(x, i) + di);
}

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint i = pc.offset + gl_GlobalInvocationID.x;
    uint p = partner.v[i];
    // Every invocation forms its own row first, outside any branch: on lavapipe the image reads
    // of the graph in divergent control flow cost several times those in uniform flow (a cell
    // forms its row for nothing, alongside its batch's unpaired inner nodes).
    vec3 ri = row_residual(i);
    vec3 a = diag.v[i].rgb;
    if (p == NO_NODE) {
        chebyshev_step(i, ri / a);
        return;
    }
    bool mutual = partner.v[p] == i;
    if (mutual && p > i) {
        return; // the block's surface node updates this one
    }
    vec3 dp = diag.v[p].rgb;
    vec3 b = RGB(partner_value, i);
    vec3 rp = row_residual(p);
    vec3 det = a * dp - b * b;
    chebyshev_step(i, (dp * ri - b * rp) / det);
    if (mutual) {
        // partner_value is the block's one off-diagonal entry, stored at both nodes.
        chebyshev_step(p, (a * rp - b * ri) / det);
    }
}
