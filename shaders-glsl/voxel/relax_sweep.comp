#version 460
// One slice of a sweep (solver::voxel::RelaxPass, Relaxation::Sweep; the fast-sweeping idea):
// the voxels of slice `slice` along `axis` take the min-plus update from the 9 voxels of the slice
// before them in the sweep direction, in place; the slices go one after another, so a sweep carries
// a path across the whole grid in one pass. Six sweeps (+-x, +-y, +-z) make a round, which covers
// all 26 neighbours (each offset has a non-zero component along some axis); a round that changes
// nothing is the fixed point, the same one Jacobi reaches (exact, equal to the CPU Dijkstra).
// Hard minimum only; every changing workgroup counts itself in control.changed.
#include "voxel_grid.glsl"
#include "relax_common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, std430) readonly buffer Grid { GridFrame grid; } grid;
layout(set = 0, binding = 1, rgba32f) uniform readonly image3D medium;
layout(set = 0, binding = 2, rgba32f) uniform image3D state;
layout(set = 0, binding = 3, std430) buffer Control { RelaxControl control; } control;

layout(push_constant) uniform SweepPush {
    uvec4 dims;   // xyz: voxels per axis
    uint axis;    // the sweep's axis
    int step;     // +1 or -1: the direction along it
    uint slice;   // the slice updated by this dispatch
    uint pad;
} pc;

shared uint s_changed;

void main() {
    if (gl_LocalInvocationIndex == 0u) {
        s_changed = 0u;
    }
    barrier();
    uint a = pc.axis;
    uint u_axis = (a + 1u) % 3u;
    uint v_axis = (a + 2u) % 3u;
    ivec3 v;
    v[a] = int(pc.slice);
    v[u_axis] = int(gl_GlobalInvocationID.x);
    v[v_axis] = int(gl_GlobalInvocationID.y);
    bool updating = in_grid(v, pc.dims.xyz);
    vec4 mv = updating ? imageLoad(medium, v) : vec4(0.0);
    updating = updating && mv.a != 0.0;
    if (updating) {
        float h = grid.grid.origin.w;
        vec3 own = imageLoad(state, v).rgb;
        vec3 best = own;
        for (int j = -1; j <= 1; ++j) {
            for (int i = -1; i <= 1; ++i) {
                ivec3 o;
                o[a] = -pc.step;
                o[u_axis] = i;
                o[v_axis] = j;
                ivec3 u = v + o;
                if (!in_grid(u, pc.dims.xyz)) {
                    continue;
                }
                vec4 mu = imageLoad(medium, u);
                if (mu.a == 0.0) {
                    continue;
                }
                precise float len = h * edge_factor(o);
                precise vec3 cand = imageLoad(state, u).rgb + edge_cost(mu.rgb, mv.rgb, len);
                best = min(best, cand);
            }
        }
        if (any(lessThan(best, own))) {
            imageStore(state, v, vec4(best, 0.0));
            atomicOr(s_changed, 1u);
        }
    }
    barrier();
    if (gl_LocalInvocationIndex == 0u && s_changed != 0u) {
        atomicAdd(control.control.changed, 1u);
    }
}
