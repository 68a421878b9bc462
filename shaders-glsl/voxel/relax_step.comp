#version 460
// One Jacobi iteration of the shortest optical path (paper section 2.1; solver::voxel::RelaxPass):
// every solid voxel reads the previous iterate of itself and its 26 neighbours (ping) and writes
// (pong)
//   hard (paper):  n_v <- min(n_v, min_u n_u + c_uv)           (min-plus, Bellman-Ford)
//   soft:          n_v <- softmin_tau(n0_v, {n_u + c_uv})      (log-sum-exp: several paths add)
// with c_uv = (sigma_u + sigma_v) / 2 * |x_u - x_v|, per colour channel. With TRACK_PATH (the
// diffusion model) the geometric length d of the chosen path is carried too, and candidates are
// compared by what they contribute at the exit, n - ln G(d) (diffusion_profile.glsl: the paper's
// "single ray which has maximum contribution", with the diffusion falloff and 1/d spreading of
// the path); on equal contributions the shorter d. Soft: the softmin of those, d the weighted
// mean, n = the softmin + ln G(d).
// Hard minimum with TRACK_PATH: one path per voxel for all three channels, the candidate whose
// summed contribution sum_c exp(-(n_c - ln G_c(d))) is largest. Chosen per channel (before), a
// voxel between two lights took red from the path through the object and blue from the one across
// the lit face: a magenta band along the terminator (issue 14's purple cast). A voxel changes only
// to a strictly better score, so the iteration still ends; the paper's model keeps the exact
// per-channel min-plus (= the CPU Dijkstra).
// Soft temperature: tau = beta * (the voxel's cheapest edge), so one step gains at most
// tau ln 27 < the edge's cost for beta < 1/ln 27: no cycle gains, the iteration is bounded.
// The hard min is exact: every value is a real path's cost, added in the same f32 order as the CPU
// Dijkstra, so the converged result equals it bit for bit.
// In the last iteration of a block, each workgroup that changed a value counts itself in
// control.changed (hard: any decrease; soft: any change above `tolerance`).
#include "voxel_grid.glsl"
#include "relax_common.glsl"
#include "diffusion_profile.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(constant_id = 0) const bool SOFT = false;
layout(constant_id = 1) const bool TRACK_PATH = false;

layout(set = 0, binding = 0, std430) readonly buffer Grid { GridFrame grid; } grid;
layout(set = 0, binding = 1, rgba32f) uniform readonly image3D medium;
layout(set = 0, binding = 2, rgba32f) uniform readonly image3D seed;
layout(set = 0, binding = 3, rgba32f) uniform readonly image3D state_in;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image3D state_out;
layout(set = 0, binding = 5, rgba32f) uniform readonly image3D path_in;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image3D path_out;
layout(set = 0, binding = 7, std430) buffer Control { RelaxControl control; } control;
// rgb: D = 1 / (3 sigma_t') per channel (diffusion model; a placeholder otherwise).
layout(set = 0, binding = 8, rgba32f) uniform readonly image3D transport;

layout(push_constant) uniform RelaxPush {
    uvec4 dims;          // xyz: voxels per axis
    float beta;          // soft temperature per unit of the cheapest edge cost
    float tolerance;     // soft: a change of n above this counts as a change
    uint flag_changes;   // 1: count changes (the block's last iteration)
    float big_a;         // A = (1 + F_dr) / (1 - F_dr) (diffusion model)
} pc;

vec3 g_diffusion;
vec3 g_s;

// What a path of optical depth n and length d contributes at this voxel, as an optical depth:
// n - ln P(d) with TRACK_PATH, n otherwise.
float objective(float n, float d, int c) {
    // why not `!TRACK_PATH`: the reflection cannot fold a spec-constant LogicalNot.
    if (TRACK_PATH) {
        if (g_diffusion[c] <= 0.0 || n >= N_UNLIT) {
            return n;
        }
    } else {
        return n;
    }
    // A floor keeps the log finite (G > 0 for every material the grid accepts).
    return n - log(max(exit_gain(g_diffusion[c], g_s[c], pc.big_a, d), 1e-30));
}

// The three channels' contributions at the exit as one optical depth, -ln sum_c exp(-f_c)
// (stable: the smallest f factored out; unreached channels add 0).
float total_contribution(vec3 f) {
    float m = min(f.x, min(f.y, f.z));
    if (m >= N_UNLIT) {
        return N_UNLIT;
    }
    return m - log(exp(m - f.x) + exp(m - f.y) + exp(m - f.z));
}

shared uint s_changed;

void main() {
    if (gl_LocalInvocationIndex == 0u) {
        s_changed = 0u;
    }
    barrier();
    ivec3 v = ivec3(gl_GlobalInvocationID);
    bool updating = in_grid(v, pc.dims.xyz);
    vec4 mv = updating ? imageLoad(medium, v) : vec4(0.0);
    updating = updating && mv.a != 0.0;
    if (updating) {
        float h = grid.grid.origin.w;
        g_diffusion = TRACK_PATH ? imageLoad(transport, v).rgb : vec3(0.0);
        g_s = mv.rgb;
        vec3 own = imageLoad(state_in, v).rgb;
        vec3 own_d = TRACK_PATH ? imageLoad(path_in, v).rgb : vec3(0.0);
        vec3 best;
        vec3 best_d;
        if (SOFT) {
            // Pass 1: the smallest objective (for a stable log-sum-exp) and the cheapest edge.
            vec3 n0 = imageLoad(seed, v).rgb;
            vec3 m;
            for (int c = 0; c < 3; ++c) {
                m[c] = objective(n0[c], 0.0, c);
            }
            vec3 cheapest = vec3(3.0e38);
            for (int z = -1; z <= 1; ++z) {
                for (int y = -1; y <= 1; ++y) {
                    for (int x = -1; x <= 1; ++x) {
                        ivec3 o = ivec3(x, y, z);
                        ivec3 u = v + o;
                        if (o == ivec3(0) || !in_grid(u, pc.dims.xyz)) {
                            continue;
                        }
                        vec4 mu = imageLoad(medium, u);
                        if (mu.a == 0.0) {
                            continue;
                        }
                        float len = h * edge_factor(o);
                        vec3 cost = edge_cost(mu.rgb, mv.rgb, len);
                        vec3 cand = imageLoad(state_in, u).rgb + cost;
                        vec3 cand_d = TRACK_PATH ? imageLoad(path_in, u).rgb + len : vec3(0.0);
                        for (int c = 0; c < 3; ++c) {
                            m[c] = min(m[c], objective(cand[c], cand_d[c], c));
                        }
                        cheapest = min(cheapest, cost);
                    }
                }
            }
            vec3 tau = pc.beta * cheapest;
            // Pass 2: sum exp(-(objective - m) / tau), and the weighted path length.
            vec3 s = vec3(0.0);
            vec3 sd = vec3(0.0);
            vec3 hard_f = vec3(3.0e38);
            vec3 hard_n = n0;
            vec3 hard_d = vec3(0.0);
            for (int c = 0; c < 3; ++c) {
                float f = objective(n0[c], 0.0, c);
                if (tau[c] > 0.0) {
                    s[c] = exp(-(f - m[c]) / tau[c]);
                }
                hard_f[c] = f;
            }
            for (int z = -1; z <= 1; ++z) {
                for (int y = -1; y <= 1; ++y) {
                    for (int x = -1; x <= 1; ++x) {
                        ivec3 o = ivec3(x, y, z);
                        ivec3 u = v + o;
                        if (o == ivec3(0) || !in_grid(u, pc.dims.xyz)) {
                            continue;
                        }
                        vec4 mu = imageLoad(medium, u);
                        if (mu.a == 0.0) {
                            continue;
                        }
                        float len = h * edge_factor(o);
                        vec3 cand = imageLoad(state_in, u).rgb + edge_cost(mu.rgb, mv.rgb, len);
                        vec3 cand_d = TRACK_PATH ? imageLoad(path_in, u).rgb + len : vec3(0.0);
                        for (int c = 0; c < 3; ++c) {
                            float f = objective(cand[c], cand_d[c], c);
                            if (tau[c] > 0.0) {
                                float weight = exp(-(f - m[c]) / tau[c]);
                                s[c] += weight;
                                sd[c] += weight * cand_d[c];
                            } else if (f < hard_f[c]) {
                                hard_f[c] = f;
                                hard_n[c] = cand[c];
                                hard_d[c] = cand_d[c];
                            }
                        }
                    }
                }
            }
            for (int c = 0; c < 3; ++c) {
                if (tau[c] > 0.0) {
                    // s >= 1: the minimum's own term. Back from the objective to n.
                    float f = m[c] - tau[c] * log(s[c]);
                    best_d[c] = sd[c] / s[c];
                    best[c] = f - objective(0.0, best_d[c], c);
                } else {
                    best[c] = hard_n[c];
                    best_d[c] = hard_d[c];
                }
            }
            // Unreached voxels stay at N_UNLIT exactly (softmin of equal N_UNLIT candidates).
            best = min(best, vec3(N_UNLIT));
        } else {
            best = own;
            best_d = own_d;
            vec3 best_f;
            for (int c = 0; c < 3; ++c) {
                best_f[c] = objective(own[c], own_d[c], c);
            }
            float best_score = total_contribution(best_f);
            for (int z = -1; z <= 1; ++z) {
                for (int y = -1; y <= 1; ++y) {
                    for (int x = -1; x <= 1; ++x) {
                        ivec3 o = ivec3(x, y, z);
                        ivec3 u = v + o;
                        if (o == ivec3(0) || !in_grid(u, pc.dims.xyz)) {
                            continue;
                        }
                        vec4 mu = imageLoad(medium, u);
                        if (mu.a == 0.0) {
                            continue;
                        }
                        precise float len = h * edge_factor(o);
                        precise vec3 cand = imageLoad(state_in, u).rgb + edge_cost(mu.rgb, mv.rgb, len);
                        precise vec3 cand_d = TRACK_PATH ? imageLoad(path_in, u).rgb + len : vec3(0.0);
                        if (TRACK_PATH) {
                            // One path for all three channels (see the header).
                            vec3 f;
                            for (int c = 0; c < 3; ++c) {
                                f[c] = objective(cand[c], cand_d[c], c);
                            }
                            float score = total_contribution(f);
                            if (score < best_score || (score == best_score && cand_d.x < best_d.x)) {
                                best_score = score;
                                best = cand;
                                best_d = cand_d;
                            }
                        } else {
                            for (int c = 0; c < 3; ++c) {
                                float f = cand[c];
                                if (f < best_f[c]) {
                                    best_f[c] = f;
                                    best[c] = cand[c];
                                }
                            }
                        }
                    }
                }
            }
        }
        imageStore(state_out, v, vec4(best, 0.0));
        if (TRACK_PATH) {
            imageStore(path_out, v, vec4(best_d, 0.0));
        }
        bool changed = SOFT ? any(greaterThan(abs(best - own), vec3(pc.tolerance)))
                            : (any(notEqual(best, own)) || (TRACK_PATH && any(notEqual(best_d, own_d))));
        if (changed && pc.flag_changes != 0u) {
            atomicOr(s_changed, 1u);
        }
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u && s_changed != 0u) {
        atomicAdd(control.control.changed, 1u);
    }
}
