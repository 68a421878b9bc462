#version 460
#extension GL_GOOGLE_include_directive : require
// Second stage of the residual norm and the convergence decision, one workgroup: sums the
// partials; mode 0 stores ||f||^2 as the reference; mode 1 logs the relative residual
// max_c ||r||_2 / ||f||_2 (absolute where f = 0) and, converged (below the tolerance, or below
// start_tolerance times the first logged residual: the start's), diverged
// (above 1e3 or not finite) or at the cycle cap, zeroes every level's indirect arguments: the
// cycles recorded after it dispatch nothing. The conjugate gradients' scalars (krylov.comp):
// mode 2 sums the apply pass's four blocks (R . z, R . z_old, z . K z, z . K dir_old) into
// rz, beta = (R . z - R . z_old) / rz_old (the flexible CG's, 0 on the first direction: rz_old =
// 0), dir . K dir = z.Kz + 2 beta z.Kdir_old + beta^2 (dir_old . K dir_old) and
// alpha = rz / (dir . K dir) (0 where not positive).
layout(local_size_x = 64) in;

#include "common.glsl"

layout(set = 0, binding = 0, std430) readonly buffer Partials { vec4 v[]; } partials;
layout(set = 0, binding = 1, std430) buffer Control { MultigridControl c; } control;

shared vec3 sums[64];

const float DIVERGED = 1e3;

// The sum over the partials from `base` (every invocation calls it: it holds barriers).
vec3 sum_partials(uint base) {
    uint lid = gl_LocalInvocationID.x;
    vec3 s = vec3(0.0);
    for (uint g = lid; g < pc.width; g += 64u) {
        s += partials.v[base + g].rgb;
    }
    sums[lid] = s;
    // why: the tree below reads every invocation's sum (shared memory RAW).
    barrier();
    for (uint stride = 32u; stride > 0u; stride >>= 1u) {
        if (lid < stride) {
            sums[lid] += sums[lid + stride];
        }
        // why: the next level of the tree reads the sums just written (shared memory RAW).
        barrier();
    }
    vec3 t = sums[0];
    // why: a second sum_partials() overwrites sums[] every invocation just read (WAR).
    barrier();
    return t;
}

bool finite(float v) {
    return !(isnan(v) || isinf(v));
}

void main() {
    if (control.c.state != 0u) {
        return;
    }
    uint lid = gl_LocalInvocationID.x;
    vec3 sum = sum_partials(0u);
    if (pc.mode == 2u) {
        vec3 against_old = sum_partials(pc.width);
        vec3 zkz = sum_partials(2u * pc.width);
        vec3 zkd = sum_partials(3u * pc.width);
        if (lid != 0u) {
            return;
        }
        vec3 rz_old = control.c.rz.rgb;
        vec3 dkd_old = control.c.dkd.rgb;
        vec3 beta = vec3(0.0);
        vec3 alpha = vec3(0.0);
        vec3 dkd = vec3(0.0);
        for (int ch = 0; ch < 3; ++ch) {
            float b = (sum[ch] - against_old[ch]) / rz_old[ch];
            beta[ch] = rz_old[ch] > 0.0 && finite(b) ? b : 0.0;
            // The first direction (beta = 0) reads no stale dir . K dir.
            float d = zkz[ch];
            if (beta[ch] != 0.0) {
                d += beta[ch] * (2.0 * zkd[ch] + beta[ch] * dkd_old[ch]);
            }
            dkd[ch] = d;
            float a = sum[ch] / d;
            alpha[ch] = d > 0.0 && finite(a) ? a : 0.0;
        }
        control.c.rz = vec4(sum, 0.0);
        control.c.beta = vec4(beta, 0.0);
        control.c.alpha = vec4(alpha, 0.0);
        control.c.dkd = vec4(dkd, 0.0);
        return;
    }
    if (lid != 0u) {
        return;
    }
    vec3 total = sum;
    if (pc.mode == 0u) {
        control.c.reference = vec4(total, 0.0);
        return;
    }
    vec3 ref = control.c.reference.rgb;
    float rel = 0.0;
    bool bad = false;
    for (int ch = 0; ch < 3; ++ch) {
        float v = ref[ch] > 0.0 ? sqrt(total[ch] / ref[ch]) : sqrt(total[ch]);
        bad = bad || isnan(v) || isinf(v);
        rel = max(rel, v);
    }
    if (bad) {
        // A non-finite residual is logged as the float maximum and stops the cycles.
        rel = 3.4e38;
    }
    uint n = control.c.logged;
    if (n < MAX_LOG) {
        control.c.residual[n] = rel;
    }
    control.c.logged = n + 1u;
    uint state = 0u;
    if (!(rel < DIVERGED)) {
        state = 2u;
    } else if (rel < pc.tolerance || (n > 0u && rel < pc.start_tolerance * control.c.residual[0])) {
        state = 1u;
    } else if (n + 1u >= pc.max_log) {
        state = 3u;
    }
    if (state != 0u) {
        control.c.state = state;
        for (int l = 0; l < MAX_LEVELS; ++l) {
            control.c.args[l].x = 0u;
        }
    }
}
