#version 460
// The bounced light as a source of the solve (`render --bounce source`; engine/src/frame/bounce/
// source.rs): after the bounce pass gathered E_b per display vertex (the irradiance that light
// leaving the surface elsewhere brings to it, in the shading's exitance units: physical), each
// finest surface node takes E_b at its position (the inverse-distance average of its nearest
// display vertices facing its way) and adds the transmitted flux T_d E_b, at the solve's exposure,
// to its q: the same boundary source as the environment's diffuse light (gather_q.comp). The
// second, warm-started solve then carries that light inside (a base's top to its front face).
layout(local_size_x = 64) in;

// [0, vertices): E_b per display vertex (the bounce pass's irradiance buffer; rgb).
layout(set = 0, binding = 0, std430) readonly buffer Irradiance { vec4 data[]; } irradiance;
// Entries of node n: entries[offsets[n] .. offsets[n + 1]), x the vertex, y the weight's bits.
layout(set = 0, binding = 1, std430) readonly buffer Offsets { uint data[]; } offsets;
layout(set = 0, binding = 2, std430) readonly buffer Entries { uvec2 data[]; } entries;
// Linear texel index of node n in the finest level's images.
layout(set = 0, binding = 3, std430) readonly buffer Texels { uint data[]; } texels;
layout(set = 0, binding = 4, rgba16f) uniform image2D q;

layout(push_constant) uniform BounceSourcePush {
    uint count;
    uint width;
    // q_scale T_d: the exposure times the diffuse transmittance of the boundary.
    float gain;
    uint pad;
} pc;

void main() {
    uint n = gl_GlobalInvocationID.x;
    if (n >= pc.count) {
        return;
    }
    vec3 e = vec3(0.0);
    for (uint k = offsets.data[n]; k < offsets.data[n + 1u]; ++k) {
        uvec2 l = entries.data[k];
        e += uintBitsToFloat(l.y) * max(irradiance.data[l.x].rgb, vec3(0.0));
    }
    vec3 add = e * pc.gain;
    bvec3 bad = bvec3(isnan(add.r) || isinf(add.r), isnan(add.g) || isinf(add.g),
                      isnan(add.b) || isinf(add.b));
    add = max(mix(add, vec3(0.0), bad), vec3(0.0));
    uint i = texels.data[n];
    ivec2 t = ivec2(int(i % pc.width), int(i / pc.width));
    vec4 old = imageLoad(q, t);
    imageStore(q, t, vec4(old.rgb + add, old.a));
}
