// Convergence decided on the GPU (DESIGN section 5), after each block of k Jacobi iterations of a
// level: one workgroup reduces max|delta phi| (the last iteration's change, latest - previous) and
// max|phi| per channel over the level's nodes (padding texels, whose first neighbour is themselves, are left out), then one
// thread updates the level's control record: iterations run, rel = max_c max|dphi_c| / max|phi_c|,
// rho = (rel / rel_previous_block)^(1/k), estimate = rel / (1 - rho); once the estimate is below the
// tolerance (or rel is exactly 0) the indirect dispatch arguments of the following blocks become 0
// groups. Same rule as the CPU reference (solver::cpu::jacobi with BLOCK = k). A block whose
// change is exactly 0 stops the level too (nothing will change any more): `stopped_early` 1
// (converged) where the state's rounding (STALL_BELOW, the format's relative half-ulp) is below
// the tolerance, else 2 (stalled: the update rounded to zero before the tolerance; fp16 phi).
// Included with DELTA_FORMAT (latest/previous), PHI_FORMAT and STALL_BELOW set.
layout(local_size_x = 256) in;

layout(set = 0, binding = 0, DELTA_FORMAT) uniform readonly image2D latest;
layout(set = 0, binding = 1, DELTA_FORMAT) uniform readonly image2D previous;
layout(set = 0, binding = 2, PHI_FORMAT) uniform readonly image2D phi;
layout(set = 0, binding = 3, rgba32ui) uniform readonly uimage2D connectivity;

struct LevelControl {
    // VkDispatchIndirectCommand of this level's iteration dispatches.
    uint groups_x;
    uint groups_y;
    uint groups_z;
    uint iterations;
    uint blocks;
    float rel_previous;
    float estimate;
    uint stopped_early;
};

layout(set = 0, binding = 4, std430) buffer Control {
    LevelControl levels[];
} control;

layout(push_constant) uniform ReducePush {
    ivec2 size;
    uint level;
    uint k;
    float tolerance;
} pc;

shared vec3 s_delta[256];
shared vec3 s_phi[256];

void main() {
    uint t = gl_LocalInvocationIndex;
    uint level = pc.level;
    // Nothing ran in this block: the state is unchanged and the decision stands.
    bool running = control.levels[level].groups_x != 0u;
    vec3 d = vec3(0.0);
    vec3 m = vec3(0.0);
    if (running) {
        uint n = uint(pc.size.x * pc.size.y);
        for (uint i = t; i < n; i += 256u) {
            ivec2 p = ivec2(int(i % uint(pc.size.x)), int(i / uint(pc.size.x)));
            if (imageLoad(connectivity, p).x == i) {
                continue;
            }
            d = max(d, abs(imageLoad(latest, p).rgb - imageLoad(previous, p).rgb));
            m = max(m, abs(imageLoad(phi, p).rgb));
        }
    }
    s_delta[t] = d;
    s_phi[t] = m;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1) {
        if (t < stride) {
            s_delta[t] = max(s_delta[t], s_delta[t + stride]);
            s_phi[t] = max(s_phi[t], s_phi[t + stride]);
        }
        barrier();
    }
    if (t != 0u || !running) {
        return;
    }
    vec3 dm = s_delta[0];
    vec3 pm = s_phi[0];
    float rel = 0.0;
    for (int c = 0; c < 3; ++c) {
        if (pm[c] > 0.0) {
            rel = max(rel, dm[c] / pm[c]);
        }
    }
    control.levels[level].iterations += pc.k;
    control.levels[level].blocks += 1u;
    bool stop = rel == 0.0;
    if (control.levels[level].blocks >= 2u && !stop) {
        float prev = control.levels[level].rel_previous;
        float rho = prev > 0.0 ? pow(rel / prev, 1.0 / float(pc.k)) : 1.0;
        // rho >= 1: not contracting yet, no estimate (the CPU reference uses infinity).
        float estimate = rho < 1.0 ? rel / (1.0 - rho) : 3.4e38;
        control.levels[level].estimate = estimate;
        stop = estimate < pc.tolerance;
    }
    if (rel == 0.0) {
        control.levels[level].estimate = 0.0;
    }
    control.levels[level].rel_previous = rel;
    if (stop) {
        control.levels[level].groups_x = 0u;
        control.levels[level].groups_y = 0u;
        // 1 converged, 2 stalled (LevelControl::STALLED).
        bool stalled = rel == 0.0 && pc.tolerance < STALL_BELOW && any(greaterThan(pm, vec3(0.0)));
        control.levels[level].stopped_early = stalled ? 2u : 1u;
    }
}
