// Shared by the diffusion passes: the per-level push constants and the neighbour gather of the
// QuadGraph textures (DESIGN section 4). One node = one texel; `connectivity` holds the 4 linear
// texel indices v * width + u of the neighbours (padding and unused slots point to the texel
// itself, with weight 0); `weight_r/g/b` hold, per channel, the Jacobi weights a_ik / a_ii of the
// 4 neighbours (computed in f64 on the CPU, see solver/gpu/textures.rs). A surface node (row
// v < surface_rows) has one neighbour, in slot 0; its slot 1 holds the source gain
// 4 / (1 - F_dr) / a_ss of Eq. 9 instead of a weight.
#ifndef GRAPH_COMMON_GLSL
#define GRAPH_COMMON_GLSL

layout(push_constant) uniform LevelPush {
    ivec2 size;
    uint width;
    uint surface_rows;
    // Homogeneous material only (graph_weights.glsl with HOMOGENEOUS): kappa per channel and the
    // Robin coefficient 2A in kappa.a; mu per channel and q_gain = 4 / (1 - F_dr) in mu_gain.a.
    vec4 kappa;
    vec4 mu_gain;
} pc;

ivec2 texel_of(uint linear) {
    return ivec2(int(linear % pc.width), int(linear / pc.width));
}

bool is_surface_row(ivec2 p) {
    return uint(p.y) < pc.surface_rows;
}

bool outside(ivec2 p) {
    return p.x >= pc.size.x || p.y >= pc.size.y;
}

#endif
