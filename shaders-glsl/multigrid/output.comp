#version 460
#extension GL_GOOGLE_include_directive : require
// The finest level's solution into the phi image the J+ pass reads (the cascade's result image);
// a non-finite value (a diverged solve, reported by the control record) is written as 0.
layout(local_size_x = 64) in;

#include "common.glsl"

layout(set = 0, binding = 0, rgba32f) uniform writeonly image2D phi;
layout(set = 0, binding = 1, std430) readonly buffer Xs { float v[]; } x;
layout(set = 0, binding = 2, std430) readonly buffer NodeTexel { uint v[]; } node_texel;

void main() {
    if (gl_GlobalInvocationID.x >= pc.count) {
        return;
    }
    uint node = gl_GlobalInvocationID.x;
    // x is phi times the solve's power-of-two scale (GpuMultigrid::scale); alpha.x undoes it.
    vec3 v = RGB(x, pc.offset + node) * pc.alpha.x;
    bvec3 bad = bvec3(isnan(v.r) || isinf(v.r), isnan(v.g) || isinf(v.g), isnan(v.b) || isinf(v.b));
    v = mix(v, vec3(0.0), bad);
    uint t = node_texel.v[node];
    imageStore(phi, ivec2(int(t % pc.width), int(t / pc.width)), vec4(v, 0.0));
}
