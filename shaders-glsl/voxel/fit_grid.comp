#version 460
// The voxel grid of this frame (solver::voxel::GridFitPass): one workgroup reduces the bounds of
// the mesh's vertex positions (non-finite ones skipped), then fits the fixed dims around them with
// cubic voxels: h = max over axes of extent / (dims - 2), one empty voxel of margin on each side,
// the box centred on the bounds. Deterministic (min/max in a fixed tree), no atomics.
#include "voxel_grid.glsl"

layout(local_size_x = 256) in;

layout(set = 0, binding = 0, std430) readonly buffer Vertices { float values[]; } vertices;
layout(set = 0, binding = 1, std430) writeonly buffer Grid { GridFrame grid; } grid;

layout(push_constant) uniform FitPush {
    uvec4 dims;         // xyz: voxels per axis
    uint vertex_count;
    uint stride;        // floats per vertex (the position is the first three)
    float min_h;        // h never below this (a mesh collapsed to a point), mm
    float pad;
} pc;

shared vec3 s_lo[256];
shared vec3 s_hi[256];
shared float s_count[256];

void main() {
    uint t = gl_LocalInvocationIndex;
    vec3 lo = vec3(3.0e38);
    vec3 hi = vec3(-3.0e38);
    float count = 0.0;
    for (uint i = t; i < pc.vertex_count; i += 256u) {
        uint b = i * pc.stride;
        vec3 p = vec3(vertices.values[b], vertices.values[b + 1u], vertices.values[b + 2u]);
        if (any(isnan(p)) || any(isinf(p))) {
            continue;
        }
        lo = min(lo, p);
        hi = max(hi, p);
        count += 1.0;
    }
    s_lo[t] = lo;
    s_hi[t] = hi;
    s_count[t] = count;
    barrier();
    for (uint stride = 128u; stride > 0u; stride >>= 1) {
        if (t < stride) {
            s_lo[t] = min(s_lo[t], s_lo[t + stride]);
            s_hi[t] = max(s_hi[t], s_hi[t + stride]);
            s_count[t] += s_count[t + stride];
        }
        barrier();
    }
    if (t != 0u) {
        return;
    }
    lo = s_lo[0];
    hi = s_hi[0];
    if (s_count[0] == 0.0) {
        // No finite vertex: an empty grid at the origin (every voxel outside).
        lo = vec3(0.0);
        hi = vec3(0.0);
    }
    vec3 extent = hi - lo;
    vec3 inner = vec3(pc.dims.xyz) - 2.0;
    float h = max(max(extent.x / inner.x, extent.y / inner.y), max(extent.z / inner.z, pc.min_h));
    vec3 centre = 0.5 * (lo + hi);
    grid.grid.origin = vec4(centre - 0.5 * vec3(pc.dims.xyz) * h, h);
    grid.grid.lo = vec4(lo, s_count[0]);
    grid.grid.hi = vec4(hi, 0.0);
    grid.grid.dims = uvec4(pc.dims.xyz, pc.dims.x * pc.dims.y * pc.dims.z);
}
