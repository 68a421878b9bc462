#version 460
#extension GL_GOOGLE_include_directive : require
// Flexible preconditioned conjugate gradients around the V-cycle (Notay 2000; the CPU's
// `Hierarchy::solve` with `krylov`), on the finest level, one invocation per node, two passes per
// iteration: K z is formed once and K dir follows from it by the direction's recurrence,
// K dir = K z + beta K dir_old, and dir . K dir = z.Kz + 2 beta z.Kdir_old + beta^2 dir_old.Kdir_old
// (so no pass waits for beta before its matrix-vector product). The CG residual R lives in the
// finest level's f (the V-cycle's right-hand side), the preconditioned residual z = V(R) in its x
// (the V-cycle starts from x = 0), K z in its r, the iterate in `sol`, the search direction in
// `dir`, K dir in `kdir`, the last z in `z_old`. Scalars (beta, alpha, dir . K dir) come from
// the control record, which the check kernel writes from this kernel's partial sums.
// Modes:
//   0 start:  sol = x, f = f - K x (= r, the start's residual), x = 0
//   1 apply:  r = K z; partials (R . z, R . z_old, z . K z, z . K dir_old), four blocks of
//             `sums` workgroup sums
//   2 step:   dir = z + beta dir, kdir = K z + beta kdir (dir = z, kdir = K z where beta = 0),
//             sol += alpha dir, R -= alpha kdir, z_old = z, x = 0; partials = R . R
//   3 start with its residual: sol = x, f = f - K x, partials = f . f (the start's residual
//             pass, its norm and mode 0 in one pass; x is left as it is: the V-cycle after it
//             starts with a step from zero, which does not read x)
//   5 finish: x = sol (the solution the output pass writes and the next warm start reads)
layout(local_size_x = 64) in;
// The finest level's entries sit at floats 3 (e - HALF_ENTRIES) of `values` (residual.comp: the
// coarse levels' fp16 entries come first and live elsewhere); under GRAPH_FINEST K comes from
// the cascade's graph textures (graph_operator.glsl) instead.
layout(constant_id = 0) const uint HALF_ENTRIES = 0u;
// TEXEL_READS: K z reads z, the diagonal, the rows and the graph's maps through uniform texel
// buffers over the same buffers (the `*_t` bindings; residual.comp).
layout(constant_id = 9) const bool TEXEL_READS = false;

#include "common.glsl"

layout(set = 0, binding = 0, std430) buffer Xs { float v[]; } x;
layout(set = 0, binding = 1, std430) buffer Fs { float v[]; } f;
layout(set = 0, binding = 2, std430) buffer Rs { float v[]; } r;
layout(set = 0, binding = 3, std430) buffer Sol { float v[]; } sol;
layout(set = 0, binding = 4, std430) buffer Dir { float v[]; } dir;
layout(set = 0, binding = 5, std430) buffer ZOld { uint v[]; } z_old;
layout(set = 0, binding = 6, std430) readonly buffer RowStart { uint v[]; } row_start;
layout(set = 0, binding = 7, std430) readonly buffer Cols { uint v[]; } cols;
layout(set = 0, binding = 8, std430) readonly buffer Values { float v[]; } values;
layout(set = 0, binding = 9, std430) readonly buffer Diag { vec4 v[]; } diag;
layout(set = 0, binding = 10, std430) writeonly buffer Partials { vec4 v[]; } partials;
layout(set = 0, binding = 11, std430) readonly buffer Control { MultigridControl c; } control;
layout(set = 0, binding = 12, std430) buffer KDir { float v[]; } kdir;
layout(set = 0, binding = 13) uniform samplerBuffer x_t;
layout(set = 0, binding = 14) uniform samplerBuffer diag_t;
layout(set = 0, binding = 15) uniform usamplerBuffer row_start_t;
layout(set = 0, binding = 16) uniform usamplerBuffer cols_t;
layout(set = 0, binding = 17) uniform samplerBuffer values_t;
layout(set = 0, binding = 18) uniform usamplerBuffer node_texel_t;
layout(set = 0, binding = 19) uniform usamplerBuffer texel_node_t;

// (Only K z reads through these: z is not written in the passes that form it.)
#define READ_X(i) (TEXEL_READS ? RGB_TEXELS(x_t, i) : RGB(x, i))
#define READ_U(buf, i) (TEXEL_READS ? texelFetch(buf##_t, int(i)).x : buf.v[i])
#define GRAPH_NODE_TEXEL(node) READ_U(node_texel, node)
#define GRAPH_TEXEL_NODE(texel) READ_U(texel_node, texel)
#define GRAPH_X(i) READ_X(i)
#include "graph_operator.glsl"

#define MODE_START 0u
#define MODE_APPLY 1u
#define MODE_STEP 2u
#define MODE_START_RESIDUAL 3u
#define MODE_FINISH 5u

// Up to four sums per invocation (the apply pass's four dot products).
shared vec3 sums[4][64];

// Workgroup sums of the first `blocks` of `s` into partials[b * pc.sums + group] (every invocation
// calls it: it holds a barrier). One barrier, then one invocation per sum adds the 64 values in
// order: on lavapipe a workgroup barrier costs more than 64 additions, and the shared-memory tree
// (six levels, a barrier each) made the CG's reductions a fifth of its iteration (benches/RESULTS.md
// "Time per work unit (wave 9)").
void reduce(vec3 s[4], uint blocks, uint group) {
    uint lid = gl_LocalInvocationID.x;
    for (uint b = 0u; b < blocks; ++b) {
        sums[b][lid] = s[b];
    }
    // why: the sums below read every invocation's values (shared memory RAW).
    barrier();
    if (lid < blocks) {
        vec3 t = vec3(0.0);
        for (uint k = 0u; k < 64u; ++k) {
            t += sums[lid][k];
        }
        partials.v[lid * pc.sums + group] = vec4(t, 0.0);
    }
}

// (K v)_i of the finest level's operator for v = x (z) of the concatenated vectors.
vec3 apply_k(uint i) {
    vec3 k_ii = TEXEL_READS ? texelFetch(diag_t, int(i)).rgb : diag.v[i].rgb;
    if (reads_graph(pc.offset)) {
        return graph_apply(i - pc.offset, i, k_ii);
    }
    vec3 acc = k_ii * READ_X(i);
    for (uint e = READ_U(row_start, i); e < READ_U(row_start, i + 1u); ++e) {
        uint j = 3u * (e - HALF_ENTRIES);
        vec3 v = TEXEL_READS ? vec3(texelFetch(values_t, int(j)).x,
                                    texelFetch(values_t, int(j + 1u)).x,
                                    texelFetch(values_t, int(j + 2u)).x)
                             : vec3(values.v[j], values.v[j + 1u], values.v[j + 2u]);
        acc += v * READ_X(READ_U(cols, e));
    }
    return acc;
}

void main() {
    uint node = gl_GlobalInvocationID.x;
    bool inside = node < pc.count;
    uint i = pc.offset + node;
    uint group = gl_WorkGroupID.x;
    if (pc.mode == MODE_APPLY) {
        vec3 rz = vec3(0.0);
        vec3 rz_old = vec3(0.0);
        vec3 zkz = vec3(0.0);
        vec3 zkd = vec3(0.0);
        if (inside) {
            vec3 z = RGB(x, i);
            vec3 kz = apply_k(i);
            SET_RGB(r, i, kz);
            vec3 rr = RGB(f, i);
            rz = rr * z;
            rz_old = rr * LOAD_UPDATE(z_old, node);
            zkz = z * kz;
            // kdir holds K dir of the last direction (stale before the first: beta = 0 then,
            // and the check ignores this sum).
            zkd = z * RGB(kdir, node);
        }
        vec3 four[4] = vec3[4](rz, rz_old, zkz, zkd);
        reduce(four, 4u, group);
        return;
    }
    if (pc.mode == MODE_STEP) {
        vec3 s = vec3(0.0);
        if (inside) {
            vec3 z = RGB(x, i);
            vec3 kz = RGB(r, i);
            vec3 beta = control.c.beta.rgb;
            vec3 alpha = control.c.alpha.rgb;
            // beta = 0 (the first direction) must not multiply a stale (possibly non-finite)
            // dir or kdir.
            bvec3 first = equal(beta, vec3(0.0));
            vec3 d = mix(z + beta * RGB(dir, node), z, first);
            vec3 kd = mix(kz + beta * RGB(kdir, node), kz, first);
            SET_RGB(dir, node, d);
            SET_RGB(kdir, node, kd);
            STORE_UPDATE(z_old, node, z);
            SET_RGB(x, i, vec3(0.0));
            SET_RGB(sol, node, RGB(sol, node) + alpha * d);
            vec3 rr = RGB(f, i) - alpha * kd;
            SET_RGB(f, i, rr);
            s = rr * rr;
        }
        reduce(vec3[4](s, s, s, s), 1u, group);
        return;
    }
    if (pc.mode == MODE_START_RESIDUAL) {
        vec3 s = vec3(0.0);
        if (inside) {
            vec3 rr = RGB(f, i) - apply_k(i);
            SET_RGB(f, i, rr);
            SET_RGB(sol, node, RGB(x, i));
            s = rr * rr;
        }
        reduce(vec3[4](s, s, s, s), 1u, group);
        return;
    }
    if (!inside) {
        return;
    }
    if (pc.mode == MODE_START) {
        SET_RGB(sol, node, RGB(x, i));
        SET_RGB(f, i, RGB(r, i));
        SET_RGB(x, i, vec3(0.0));
    } else if (pc.mode == MODE_FINISH) {
        SET_RGB(x, i, RGB(sol, node));
    }
}
