#version 460
#extension GL_GOOGLE_include_directive : require
// Mixed precision, end of a block: phi += delta (fp32 state, fp16 correction).
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D delta;
layout(set = 0, binding = 1, rgba32f) uniform image2D phi;

#include "graph_common.glsl"

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (outside(p)) {
        return;
    }
    imageStore(phi, p, imageLoad(phi, p) + vec4(imageLoad(delta, p).rgb, 0.0));
}
