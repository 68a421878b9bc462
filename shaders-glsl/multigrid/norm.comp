#version 460
#extension GL_GOOGLE_include_directive : require
// First stage of the residual norm: per workgroup, sum of r^2 per channel (mode 1: of f) over the
// finest level, into partials[group] (the check kernel sums the partials).
layout(local_size_x = 64) in;

#include "common.glsl"

layout(set = 0, binding = 0, std430) readonly buffer Fs { float v[]; } f;
layout(set = 0, binding = 1, std430) readonly buffer Rs { float v[]; } r;
layout(set = 0, binding = 2, std430) writeonly buffer Partials { vec4 v[]; } partials;

shared vec3 sums[64];

void main() {
    uint lid = gl_LocalInvocationID.x;
    vec3 s = vec3(0.0);
    if (gl_GlobalInvocationID.x < pc.count) {
        uint i = pc.offset + gl_GlobalInvocationID.x;
        vec3 v = pc.mode == 1u ? RGB(f, i) : RGB(r, i);
        s = v * v;
    }
    sums[lid] = s;
    // why: invocation 0 reads every invocation's square (shared memory RAW).
    barrier();
    // One barrier and a sum in order instead of a tree of six (krylov.comp's reduce()).
    if (lid == 0u) {
        vec3 t = vec3(0.0);
        for (uint k = 0u; k < 64u; ++k) {
            t += sums[k];
        }
        partials.v[gl_WorkGroupID.x] = vec4(t, 0.0);
    }
}
