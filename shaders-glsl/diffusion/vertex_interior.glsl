// Per display-mesh vertex exitance reconstructed from the interior solution (DESIGN 2.6, issue 12
// item 4), the GPU twin of `solver::cpu::interior_vertices` (same formulas, f32):
//   p      = sum_k w_k phi(node_k): phi at the vertex's sample point a fixed depth inside along
//            its normal (the bake's `SurfaceSamples`: moving least squares over 16 inner nodes);
//   q, P   = the surface nodes' q and collimated exit part averaged with the vertex's source
//            weights (the bake's `SurfaceSamples::sources`: up to 16 surface nodes within 1.5
//            finest spacings, so a scan's bumps do not show through the nodes' cosines; the
//            lattice is in phi_s - phi_k, which is no longer read); with own visibility (push
//            scale.z 2, wave 13) the lit beam's part of both at the vertex's own light visibility
//            (`vertex_particular`'s alpha, the gather run at the display vertices) where that is
//            below the nodes' (their particular alpha), so a cast shadow's dark side ends at the
//            display mesh's edge, not ~1.5 spacings into it;
//   p'     = p read back onto the profile: the weights are exact for linear phi only, and the
//            profile's Hessian over the nodes' second moments adds (phi_zz m_nn - kappa phi_z
//            m_tt) / 2, linear in (p', rhs) (`solver::transport::sample_on_profile`);
//   lambda = the lateral term (wave 11): the along-surface Laplacian of the samples p over the
//            vertex's lateral stencil (the bake's `SurfaceSamples::lateral`: its own and up to 15
//            neighbouring vertices' samples) divided by its own p, a negative one cut by its lit
//            share rhs / (rhs + p) (wave 13), |lambda| depth^2 <= 1
//            (`solver::transport::lateral_lambda`); two stages (push scale.w): 0 writes every
//            vertex's p to `sample_phi`, 1 reads them back and does the rest;
//   phi0, dphi0 = the local 1D profile through p' at `depth` on a surface of mean curvature H:
//            g = phi (1 - H z), g'' = (s^2 - lambda) g (cos / sin where negative), Robin g(0) (1 - h H) - h g'(0) = rhs = flux_gain q,
//            phi0 = g(0), dphi0 = g'(0) + H g(0) (h = 2 A D, s = sqrt(mu / D), D and mu of the
//            tetrahedron holding the sample: `solver::transport::curved_profile_from_sample`,
//            H clamped to PROFILE_CURVATURE_LIMIT / depth);
//   M      = the exit query (flux: (1 - F_dr)((1 + 1/A) phi0 / 4 - q / (1 + F_dr)); moments:
//            (1 - 2 C1) phi0 / 4 + (1 - 3 C2) D dphi0 / 2) + P;
//   X      = M times the shading input per unit exitance, unscaled from the exposure, clamped at 0
//            (a smooth field, so the clamp follows the physics, not the lattice).
// Writes rgb X at floats [v * stride + offset, +3) of `vertex_j_plus` (as vertex_j_plus.comp).
// Included with PHI_FORMAT set.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0, PHI_FORMAT) uniform readonly image2D phi;
layout(set = 0, binding = 1, rgba16f) uniform readonly image2D q;
layout(set = 0, binding = 2, rgba16f) uniform readonly image2D particular;
// Heterogeneous materials only (push flag): per-node kappa and mu of the finest level.
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D kappa;
layout(set = 0, binding = 4, rgba32f) uniform readonly image2D mu;
// Per vertex 4 uvec4: 16 linear texel indices of surface nodes; 4 vec4: their source weights.
layout(set = 0, binding = 5, std430) readonly buffer SourceNodes { uvec4 nodes[]; } source_nodes;
layout(set = 0, binding = 6, std430) readonly buffer SourceWeights { vec4 weights[]; } source_weights;
// Per vertex 4 uvec4: 16 linear texel indices of the sample's inner nodes; 4 vec4: their weights.
layout(set = 0, binding = 7, std430) readonly buffer SampleNodes { uvec4 nodes[]; } sample_nodes;
layout(set = 0, binding = 8, std430) readonly buffer SampleWeights { vec4 weights[]; } sample_weights;
// Per vertex: x the sample cell's linear texel index, y the sample depth (mm, float bits), z the
// smoothed surface's mean curvature (1/mm, float bits, positive where convex), w the sample
// nodes' second moments (m_nn, m_tt) in mm^2 as two halves (`SurfaceSamples::spread`).
layout(set = 0, binding = 9, std430) readonly buffer SampleCells { uvec4 cells[]; } sample_cells;
layout(set = 0, binding = 10, std430) writeonly buffer VertexJPlus { float values[]; } vertex_j_plus;
// Per vertex its sample's phi (rgb), written by stage 0 and read by stage 1.
layout(set = 0, binding = 11, std430) buffer SamplePhi { vec4 values[]; } sample_phi;
// Per vertex 4 uvec4: 16 vertex ids of its lateral stencil; 4 vec4: their weights (1/mm^2).
layout(set = 0, binding = 12, std430) readonly buffer LateralNodes { uvec4 nodes[]; } lateral_nodes;
layout(set = 0, binding = 13, std430) readonly buffer LateralWeights { vec4 weights[]; } lateral_weights;
// The gather at the display vertices themselves (`solver::gpu::interior`'s vertex level, vertex v
// at texel (v % VERTEX_GATHER_WIDTH, v / VERTEX_GATHER_WIDTH)): rgb the vertex's own collimated
// exit part, a its own light visibility where that part is the lit beam's (-1 elsewhere).
layout(set = 0, binding = 14, rgba16f) uniform readonly image2D vertex_particular;

// `solver::gpu::interior::VERTEX_GATHER_WIDTH`.
const uint VERTEX_GATHER_WIDTH = 256u;
// `solver::cpu::OWN_VISIBILITY_LIT`.
const float OWN_VISIBILITY_LIT = 1e-3;

// `solver::transport::PROFILE_CURVATURE_LIMIT`.
const float PROFILE_CURVATURE_LIMIT = 0.5;
// `solver::transport::SAMPLE_CORRECTION_LIMIT`.
const float SAMPLE_CORRECTION_LIMIT = 0.25;
// `solver::transport::LATERAL_LIMIT`.
const float LATERAL_LIMIT = 1.0;

// sinh(x) / s_eff and cosh(x) of x = s_eff depth, s_eff^2 = s2 (s^2 - lambda), or sin(x) / w
// and cos(x) where s2 = -w^2 < 0 (w depth <= 1 by the clamp).
vec2 profile_terms(float s2, float depth) {
    if (s2 >= 0.0) {
        float s = sqrt(s2);
        float x = s * depth;
        // sinh(s depth) / s with its s -> 0 limit; cosh (exp overflow: far beyond any sample).
        float sinh_over_s = x < 1e-3 ? depth * (1.0 + x * x / 6.0) : sinh(min(x, 80.0)) / s;
        return vec2(sinh_over_s, cosh(min(x, 80.0)));
    }
    float w = sqrt(-s2);
    float x = w * depth;
    float sin_over_w = x < 1e-3 ? depth * (1.0 - x * x / 6.0) : sin(x) / w;
    return vec2(sin_over_w, cos(x));
}

// `solver::transport::LATERAL_FLOOR`.
const float LATERAL_FLOOR = 0.5;
// `solver::transport::LATERAL_LIT_CUT`.
const float LATERAL_LIT_CUT = 1.0;

// `solver::transport::lateral_lambda`: the stencil's Laplacian over the sample, less the noise
// floor LATERAL_FLOOR s^2; a negative one (a lateral maximum) times 1 - LATERAL_LIT_CUT rhs /
// (rhs + p) (its lit share); clamped.
float lateral_lambda(float laplacian, float p, float s, float depth, float rhs) {
    if (!(p > 0.0) || !(depth > 0.0) || isinf(p)) {
        return 0.0;
    }
    float lambda = laplacian / p;
    if (isnan(lambda) || isinf(lambda)) {
        return 0.0;
    }
    lambda = sign(lambda) * max(abs(lambda) - LATERAL_FLOOR * s * s, 0.0);
    if (lambda < 0.0 && rhs > 0.0) {
        lambda *= max(1.0 - LATERAL_LIT_CUT * rhs / (rhs + p), 0.0);
    }
    float limit = LATERAL_LIMIT / (depth * depth);
    return clamp(lambda, -limit, limit);
}

// g(0) of the curved profile through phi = p at `depth` with Robin right-hand side rhs, g'' =
// s2 g (`solver::transport::lateral_profile_from_sample`; k and lambda already clamped).
float profile_g0(float p, float rhs, float s2, float h, float depth, float k) {
    vec2 t = profile_terms(s2, depth);
    return (p * (1.0 - k * depth) + rhs * t.x / h) / (t.y + (1.0 - h * k) * t.x / h);
}

// The bias (phi_zz m_nn + (lambda p / 2 - kappa phi_z) m_tt) / 2 that the sample's linear
// weights add to the profile through (p, rhs) (`solver::transport::sample_on_lateral_profile`).
float profile_bias(float p, float rhs, float s, float lambda, float h, float depth, float k,
                   vec2 spread) {
    float s2 = s * s - lambda;
    float g0 = profile_g0(p, rhs, s2, h, depth, k);
    float ck = 1.0 - k * depth;
    float gd = p * ck;
    float dgd;
    if (s2 >= 0.0) {
        float se = sqrt(s2);
        float x = se * depth;
        if (x < 1e-6) {
            dgd = (gd - g0) / max(depth, 1e-30);
        } else if (x > 80.0) {
            dgd = se * gd;
        } else {
            dgd = se * (gd / tanh(x) - g0 / sinh(x));
        }
    } else {
        float w = sqrt(-s2);
        float x = w * depth;
        if (x < 1e-6) {
            dgd = (gd - g0) / max(depth, 1e-30);
        } else {
            dgd = w * (gd / tan(x) - g0 / sin(x));
        }
    }
    float kappa = k / ck;
    float phi_z = (dgd + k * p) / ck;
    float phi_zz = s2 * p + 2.0 * kappa * phi_z;
    return 0.5 * (phi_zz * spread.x + (0.5 * lambda * p - kappa * phi_z) * spread.y);
}

layout(push_constant) uniform InteriorPush {
    uint count;
    uint width;
    uint stride;
    uint offset;
    vec4 kappa;     // homogeneous: D rgb; a: 1 = read the kappa / mu images (heterogeneous)
    vec4 mu;        // homogeneous: sigma_a rgb; a: 2A (h = 2 A D)
    vec4 exit;      // x: phi factor, y: D dphi factor, z: q factor (flux query), w: flux gain
    vec4 scale;     // x: 1 / q_scale, y: shading input per unit exitance, z: 1 = add P, 2 = add
                    // P, the beam's q and P at the vertex's own visibility,
                    // w: the stage (0: the samples' phi into sample_phi, 1: the exitance)
} pc;

ivec2 texel(uint linear) {
    return ivec2(int(linear % pc.width), int(linear / pc.width));
}

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.count) {
        return;
    }
    if (pc.scale.w < 0.5) {
        // Stage 0: phi at the sample point.
        vec3 p = vec3(0.0);
        for (uint g = 0u; g < 4u; ++g) {
            uvec4 n = sample_nodes.nodes[4u * v + g];
            vec4 w = sample_weights.weights[4u * v + g];
            for (int k = 0; k < 4; ++k) {
                if (w[k] != 0.0) {
                    p += w[k] * imageLoad(phi, texel(n[k])).rgb;
                }
            }
        }
        sample_phi.values[v] = vec4(p, 0.0);
        return;
    }
    vec3 p = sample_phi.values[v].rgb;
    // The samples' along-surface Laplacian (the lateral stencil; all weights 0 without one).
    vec3 laplacian = vec3(0.0);
    for (uint g = 0u; g < 4u; ++g) {
        uvec4 n = lateral_nodes.nodes[4u * v + g];
        vec4 w = lateral_weights.weights[4u * v + g];
        for (int k = 0; k < 4; ++k) {
            if (w[k] != 0.0) {
                laplacian += w[k] * sample_phi.values[n[k]].rgb;
            }
        }
    }
    // The sources at the vertex.
    vec3 qv = vec3(0.0);
    vec3 part = vec3(0.0);
    // The lit beam's share of q and P (nodes whose particular alpha is their visibility, both
    // then proportional to it), its weight and its visibility-weighted weight.
    vec3 q_beam = vec3(0.0);
    vec3 part_beam = vec3(0.0);
    float w_beam = 0.0;
    float w_vis = 0.0;
    for (uint g = 0u; g < 4u; ++g) {
        uvec4 l = source_nodes.nodes[4u * v + g];
        vec4 sw = source_weights.weights[4u * v + g];
        for (int k = 0; k < 4; ++k) {
            if (sw[k] != 0.0) {
                ivec2 t = texel(l[k]);
                vec3 qk = imageLoad(q, t).rgb;
                qv += sw[k] * qk;
                if (pc.scale.z > 0.5) {
                    vec4 pk = imageLoad(particular, t);
                    part += sw[k] * pk.rgb;
                    if (pk.a >= 0.0) {
                        q_beam += sw[k] * qk;
                        part_beam += sw[k] * pk.rgb;
                        w_beam += sw[k];
                        w_vis += sw[k] * pk.a;
                    }
                }
            }
        }
    }
    if (pc.scale.z > 1.5) {
        // The shading point's own visibility (`solver::cpu::own_visibility_sources`): the beam
        // nodes' q and P per unit visibility, times the vertex's own (the gather's shadow lookup
        // at the vertex) where that is below the nodes' (a cast shadow's dark side: a lit vertex
        // keeps the nodes' average); unchanged where no beam node is lit or the vertex has none.
        float own = imageLoad(vertex_particular,
                              ivec2(int(v % VERTEX_GATHER_WIDTH), int(v / VERTEX_GATHER_WIDTH))).a;
        if (own >= 0.0 && w_vis > OWN_VISIBILITY_LIT * w_beam) {
            float f = min(own * w_beam / w_vis, 1.0) - 1.0;
            qv += f * q_beam;
            part += f * part_beam;
        }
    }
    uvec4 cell = sample_cells.cells[v];
    float depth = uintBitsToFloat(cell.y);
    float curvature = uintBitsToFloat(cell.z);
    vec2 spread = unpackHalf2x16(cell.w);
    vec3 d = pc.kappa.rgb;
    vec3 sigma_a = pc.mu.rgb;
    if (pc.kappa.a > 0.5) {
        d = imageLoad(kappa, texel(cell.x)).rgb;
        sigma_a = imageLoad(mu, texel(cell.x)).rgb;
    }
    vec3 rhs = pc.exit.w * qv;
    vec3 m;
    for (int c = 0; c < 3; ++c) {
        float h = pc.mu.a * d[c];
        float s = sqrt(max(sigma_a[c], 0.0) / max(d[c], 1e-30));
        float limit = depth > 0.0 ? PROFILE_CURVATURE_LIMIT / depth : 0.0;
        float k = clamp(curvature, -limit, limit);
        float lambda = lateral_lambda(laplacian[c], p[c], s, depth, rhs[c]);
        // The sample read back onto the profile: the linear weights' bias is linear in (p, rhs).
        float p_sample = p[c];
        if (spread.x != 0.0 || spread.y != 0.0) {
            float b_p = profile_bias(1.0, 0.0, s, lambda, h, depth, k, spread);
            float b_r = profile_bias(0.0, 1.0, s, lambda, h, depth, k, spread);
            if (abs(b_p) > SAMPLE_CORRECTION_LIMIT) {
                float f = SAMPLE_CORRECTION_LIMIT / abs(b_p);
                b_p *= f;
                b_r *= f;
            }
            float corrected = (p[c] - rhs[c] * b_r) / (1.0 + b_p);
            if (!isnan(corrected) && !isinf(corrected)) {
                p_sample = corrected;
            }
        }
        float g0 = profile_g0(p_sample, rhs[c], s * s - lambda, h, depth, k);
        float phi0 = g0;
        float dphi0 = (g0 * (1.0 - h * k) - rhs[c]) / h + k * g0;
        m[c] = pc.exit.x * phi0 + pc.exit.y * d[c] * dphi0 - pc.exit.z * qv[c];
    }
    vec3 raw = (m * pc.scale.y + part * pc.scale.y) * pc.scale.x;
    for (int c = 0; c < 3; ++c) {
        if (!(raw[c] >= 0.0)) {
            raw[c] = 0.0;
        }
    }
    uint base = v * pc.stride + pc.offset;
    vertex_j_plus.values[base] = raw.r;
    vertex_j_plus.values[base + 1u] = raw.g;
    vertex_j_plus.values[base + 2u] = raw.b;
}
