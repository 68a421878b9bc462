#version 460
// Dipole method, irradiance at the leaves (Mertens et al. 2003, section 5.3: "irradiance is
// computed at each leaf cluster (triangle)"): the shared irradiance gather wrote the transmitted
// irradiance E T_i of triangle i at texel (i % width, i / width) of `q`, pre-scaled for fp16; this
// unscales it into the hierarchy's leaf buffer (one vec4 per triangle, rgb, w = 0).
layout(local_size_x = 64) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D q;
layout(set = 0, binding = 1, std430) writeonly buffer LeafIrradiance { vec4 values[]; } leaf_irradiance;

layout(push_constant) uniform LeafPush {
    uint leaf_count;
    uint width;
    float inv_q_scale;
    uint pad;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.leaf_count) {
        return;
    }
    vec3 e = imageLoad(q, ivec2(int(i % pc.width), int(i / pc.width))).rgb * pc.inv_q_scale;
    // A saturated or broken texel must not become NaN/Inf downstream.
    e = clamp(mix(vec3(0.0), e, not(isnan(e))), vec3(0.0), vec3(3.0e38));
    leaf_irradiance.values[i] = vec4(e, 0.0);
}
