#version 460
#extension GL_GOOGLE_include_directive : require
// Local relaxation of a warm start on the finest level (`MultigridParams::local_relaxation`;
// Rüde's fully adaptive multigrid, its finest level): the extrapolated start's residual sits on
// the few surface nodes a shadow edge crossed, so it is relaxed there before the cycles.
// `local` holds a header (count, the current range's begin and end, the indirect arguments of
// that range), then one flag bit per finest node (LOCAL_WORDS words), then the list of marked
// nodes (capacity LOCAL_CAPACITY; nodes past it are flagged, not listed, and not relaxed). The
// host zeroes the header and the flags every frame. The finest level's K comes from its
// compressed rows or, under GRAPH_FINEST, from the cascade's graph (graph_operator.glsl), as in
// residual.comp; a ring grows over the same row's neighbours either way (row i's columns, or
// node i's graph slots: one direction, the row's). Modes:
//   0 mark:     every finest node: r = f - K x; listed where any channel |r| > tol ||f||
//   1 ring:     one invocation: the range is the nodes listed since the last range
//   2 grow:     each node of the range lists its neighbours not flagged yet
//   3 all:      one invocation: the range is the whole list; control.local_nodes += its length
//               (a warm start with coarse corrections relaxes locally more than once)
//   4 residual: each listed node: r = f - K x (into the level's r)
//   5 step:     each listed node: x += omega B^-1 r (B the 2x2 block with the partner where the
//               partner is listed too, else the diagonal); omega in pc.beta
layout(local_size_x = 64) in;
// The finest level's entries sit at floats 3 (e - HALF_ENTRIES) of `values` (residual.comp).
layout(constant_id = 0) const uint HALF_ENTRIES = 0u;
// The `local` buffer's layout (`LocalLayout` in solver/gpu/multigrid/local.rs): flag words (one
// bit per finest node) and list entries.
layout(constant_id = 9) const uint LOCAL_WORDS = 0u;
layout(constant_id = 10) const uint LOCAL_CAPACITY = 0u;

#include "common.glsl"

layout(set = 0, binding = 0, std430) buffer Xs { float v[]; } x;
layout(set = 0, binding = 1, std430) readonly buffer Fs { float v[]; } f;
layout(set = 0, binding = 2, std430) buffer Rs { float v[]; } r;
layout(set = 0, binding = 3, std430) readonly buffer RowStart { uint v[]; } row_start;
layout(set = 0, binding = 4, std430) readonly buffer Cols { uint v[]; } cols;
layout(set = 0, binding = 5, std430) readonly buffer Values { float v[]; } values;
layout(set = 0, binding = 6, std430) readonly buffer Diag { vec4 v[]; } diag;
layout(set = 0, binding = 7, std430) readonly buffer Partner { uint v[]; } partner;
layout(set = 0, binding = 8, std430) readonly buffer PartnerValue { float v[]; } partner_value;
layout(set = 0, binding = 9, std430) buffer Control { MultigridControl c; } control;
layout(set = 0, binding = 10, std430) buffer Local { uint v[]; } local;

#include "graph_operator.glsl"

#define MODE_MARK 0u
#define MODE_RING 1u
#define MODE_GROW 2u
#define MODE_ALL 3u
#define MODE_RESIDUAL 4u
#define MODE_STEP 5u

// Header words (`LOCAL_HEADER` in solver/gpu/multigrid/local.rs); the flags follow, LOCAL_WORDS
// words, then the list.
#define COUNT 0u
#define BEGIN 1u
#define END 2u
#define ARGS 4u
#define HEADER 8u
#define LIST (HEADER + LOCAL_WORDS)

// r_i = f_i - (K x)_i of the finest level (absolute node i; f32 entries or the graph).
vec3 residual_at(uint i) {
    if (reads_graph(pc.offset)) {
        return RGB(f, i) - graph_apply(i - pc.offset, i, diag.v[i].rgb);
    }
    vec3 acc = diag.v[i].rgb * RGB(x, i);
    for (uint e = row_start.v[i]; e < row_start.v[i + 1u]; ++e) {
        uint j = 3u * (e - HALF_ENTRIES);
        acc += vec3(values.v[j], values.v[j + 1u], values.v[j + 2u]) * RGB(x, cols.v[e]);
    }
    return RGB(f, i) - acc;
}

// Flags the finest node `node`; true when this invocation flagged it first (so lists it).
bool claim(uint node) {
    uint bit = 1u << (node & 31u);
    return (atomicOr(local.v[HEADER + (node >> 5u)], bit) & bit) == 0u;
}

bool flagged(uint node) {
    return (local.v[HEADER + (node >> 5u)] & (1u << (node & 31u))) != 0u;
}

void append(uint node) {
    uint k = atomicAdd(local.v[COUNT], 1u);
    if (k < LOCAL_CAPACITY) {
        local.v[LIST + k] = node;
    }
}

void set_range(uint begin, uint end) {
    local.v[BEGIN] = begin;
    local.v[END] = end;
    local.v[ARGS] = (end - begin + 63u) / 64u;
    local.v[ARGS + 1u] = 1u;
    local.v[ARGS + 2u] = 1u;
}

void main() {
    uint id = gl_GlobalInvocationID.x;
    uint listed = min(local.v[COUNT], LOCAL_CAPACITY);
    if (pc.mode == MODE_RING || pc.mode == MODE_ALL) {
        if (id != 0u) {
            return;
        }
        if (pc.mode == MODE_RING) {
            set_range(local.v[END], listed);
        } else {
            set_range(0u, listed);
            control.c.local_nodes += listed;
        }
        return;
    }
    if (pc.mode == MODE_MARK) {
        if (id >= pc.count) {
            return;
        }
        vec3 res = residual_at(pc.offset + id);
        vec3 limit = pc.tolerance * pc.tolerance * control.c.reference.rgb;
        if (any(greaterThan(res * res, limit)) && claim(id)) {
            append(id);
        }
        return;
    }
    uint k = local.v[BEGIN] + id;
    if (k >= local.v[END]) {
        return;
    }
    uint node = local.v[LIST + k];
    uint i = pc.offset + node;
    if (pc.mode == MODE_GROW && reads_graph(pc.offset)) {
        ivec2 p = texel_of(node_texel.v[node]);
        uvec4 nb = imageLoad(connectivity, p);
        for (int s = 0; s < (uint(p.y) < pc.surface_rows ? 1 : 4); ++s) {
            uint j = texel_node.v[nb[s]];
            if (j != NO_NODE && claim(j)) {
                append(j);
            }
        }
    } else if (pc.mode == MODE_GROW) {
        for (uint e = row_start.v[i]; e < row_start.v[i + 1u]; ++e) {
            uint j = cols.v[e] - pc.offset;
            if (claim(j)) {
                append(j);
            }
        }
    } else if (pc.mode == MODE_RESIDUAL) {
        SET_RGB(r, i, residual_at(i));
    } else if (pc.mode == MODE_STEP) {
        vec3 a = diag.v[i].rgb;
        vec3 ri = RGB(r, i);
        vec3 z;
        uint p = partner.v[i];
        // The partner's r is this sweep's only where it is listed (a full list lists every
        // flagged node).
        if (p != NO_NODE && local.v[COUNT] <= LOCAL_CAPACITY && flagged(p - pc.offset)) {
            vec3 b = RGB(partner_value, i);
            vec3 dp = diag.v[p].rgb;
            z = (dp * ri - b * RGB(r, p)) / (a * dp - b * b);
        } else {
            z = ri / a;
        }
        SET_RGB(x, i, RGB(x, i) + pc.beta.rgb * z);
    }
}
