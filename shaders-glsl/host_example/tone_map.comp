#version 460
// The example host's post pass (engine/examples/host_graph.rs): exposure, Reinhard tone map and
// sRGB encoding from its HDR scene image into an 8-bit image. Not used by the library.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D hdr;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D ldr;

layout(push_constant) uniform ToneMapPush {
    ivec2 size;
    float exposure;
} pc;

vec3 srgb(vec3 c) {
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, pc.size))) {
        return;
    }
    vec3 c = max(imageLoad(hdr, p).rgb * pc.exposure, vec3(0.0));
    imageStore(ldr, p, vec4(srgb(c / (1.0 + c)), 1.0));
}
