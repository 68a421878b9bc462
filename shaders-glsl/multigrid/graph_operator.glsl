// The finest level's operator K = S A read from the cascade's graph textures (matrix-free,
// `FinestOperator::Graph`, `--finest-operator graph`; benches/RESULTS.md "Matrix-free finest
// level (wave 8)"): no compressed rows of the finest level are stored. Row i of the fv system is
// `a_ii phi_i - sum_k a_ik phi_nbr(i,k)`, and K = S A scales it by the row's `s_i` (V_i, or
// A_f / (2A) on a Robin row); the textures hold the Jacobi weights `w_ik = a_ik / a_ii` (or what
// `graph_weights.glsl` derives them from) and the multigrid's `diag` holds `K_ii = s_i a_ii`, so
//   (K v)_i = K_ii (v_i - sum_k w_ik v_nbr(i,k)),
// the CSR's row to f32 rounding (`solver::gpu::multigrid`, test `gpu_multigrid_graph`). A surface
// node's one neighbour (its cell, slot 0) is the Robin row's (DESIGN section 2, paper Eq. 6).
// The neighbours are texels (`connectivity`); `texel_node` maps them back to finest nodes,
// `node_texel` the node to its texel.
//
// Include after common.glsl and the kernel's buffer `x` (the vector K multiplies); the kernel's
// own constants take ids 0-2, 9, 10 or from 12 (11: common.glsl), its bindings numbers below 20.
#ifndef GRAPH_OPERATOR_GLSL
#define GRAPH_OPERATOR_GLSL

// The finest level's K from the graph textures (true) or from its compressed rows (false).
layout(constant_id = 6) const bool GRAPH_FINEST = false;
// The finest level's first node in the concatenated vectors (the residual kernel runs on every
// level: the finest is the dispatch at this offset).
layout(constant_id = 7) const uint FINEST_OFFSET = 0u;

layout(set = 0, binding = 24, rgba32ui) uniform readonly uimage2D connectivity;
layout(set = 0, binding = 25, std430) readonly buffer NodeTexel { uint v[]; } node_texel;
layout(set = 0, binding = 26, std430) readonly buffer TexelNode { uint v[]; } texel_node;

// How graph_apply reads node_texel, texel_node and x: a kernel that reads them another way
// (residual.comp's texel buffers) defines all three before the include.
#ifndef GRAPH_NODE_TEXEL
#define GRAPH_NODE_TEXEL(node) node_texel.v[node]
#define GRAPH_TEXEL_NODE(texel) texel_node.v[texel]
#define GRAPH_X(i) RGB(x, i)
#endif

ivec2 texel_of(uint linear) {
    return ivec2(int(linear % pc.width), int(linear / pc.width));
}

#define GRAPH_WEIGHTS_CONSTANT_ID 3
#define GRAPH_WEIGHTS_BINDING 20
#include "../diffusion/graph_weights.glsl"

// Whether the dispatch at `offset` reads the graph (the finest level under GRAPH_FINEST).
bool reads_graph(uint offset) {
    return GRAPH_FINEST && offset == FINEST_OFFSET;
}

// (K x)_i of the finest level at its node `node` (global index `i`, the level at pc.offset), with
// `k_ii` the diagonal K_ii.
vec3 graph_apply(uint node, uint i, vec3 k_ii) {
    ivec2 p = texel_of(GRAPH_NODE_TEXEL(node));
    uvec4 nb = imageLoad(connectivity, p);
    bool surface = uint(p.y) < pc.surface_rows;
    vec3 w[4];
    vec3 gain;
    node_weights(p, nb, surface, w, gain);
    vec3 acc = vec3(0.0);
    for (int k = 0; k < (surface ? 1 : 4); ++k) {
        uint j = GRAPH_TEXEL_NODE(nb[k]);
        // (Every finest node's slots are nodes; padding is never a node's neighbour.)
        if (j != NO_NODE) {
            acc += w[k] * GRAPH_X(pc.offset + j);
        }
    }
    return k_ii * (GRAPH_X(i) - acc);
}

#endif
