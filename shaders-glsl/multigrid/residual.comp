#version 460
#extension GL_GOOGLE_include_directive : require
// r = f - K x on one level (CSR rows, the diagonal apart).
layout(local_size_x = 64) in;

#include "common.glsl"

layout(set = 0, binding = 0, std430) readonly buffer Xs { vec4 v[]; } x;
layout(set = 0, binding = 1, std430) readonly buffer Fs { vec4 v[]; } f;
layout(set = 0, binding = 2, std430) writeonly buffer Rs { vec4 v[]; } r;
layout(set = 0, binding = 3, std430) readonly buffer RowStart { uint v[]; } row_start;
layout(set = 0, binding = 4, std430) readonly buffer Cols { uint v[]; } cols;
layout(set = 0, binding = 5, std430) readonly buffer Values { vec4 v[]; } values;
layout(set = 0, binding = 6, std430) readonly buffer Diag { vec4 v[]; } diag;

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint i = pc.offset + gl_GlobalInvocationID.x;
    vec3 acc = diag.v[i].rgb * x.v[i].rgb;
    for (uint e = row_start.v[i]; e < row_start.v[i + 1u]; ++e) {
        acc += values.v[e].rgb * x.v[cols.v[e]].rgb;
    }
    r.v[i] = vec4(f.v[i].rgb - acc, 0.0);
}
