#version 460
// The smooth surface gradient of the exitance per display vertex, times f D there, for the
// diffusion's tangential flux (render --tangential-flux; engine/src/frame/tangential.rs):
// grad X(v) = sum_k w_k X(u_k) over v's one ring (w_k the host's vec3 weights: the incident
// triangles' gradients averaged by area), per channel; out: 3 vec3 per vertex (grad R, grad G,
// grad B), each times factor D_c(v) (transport::Boundary::tangential_flux_factor times D).
layout(local_size_x = 64) in;

layout(set = 0, binding = 0, std430) readonly buffer Vertices { float data[]; } vertices;
// Weights of vertex v: weights[offsets[v] .. offsets[v + 1]); xyz the weight, w the neighbour's
// index bits.
layout(set = 0, binding = 1, std430) readonly buffer Offsets { uint data[]; } offsets;
layout(set = 0, binding = 2, std430) readonly buffer Weights { vec4 data[]; } weights;
// D per vertex (rgb, mm).
layout(set = 0, binding = 3, std430) readonly buffer Diffusion { vec4 data[]; } diffusion;
layout(set = 0, binding = 4, std430) writeonly buffer Gradient { float data[]; } gradient;

layout(push_constant) uniform TangentialPush {
    uint count;
    uint stride;
    uint offset;
    float factor;
} pc;

vec3 exitance(uint v) {
    uint base = v * pc.stride + pc.offset;
    return vec3(vertices.data[base], vertices.data[base + 1u], vertices.data[base + 2u]);
}

// Never a NaN or an Inf out of the pass.
vec3 clean(vec3 x) {
    bvec3 bad = bvec3(isnan(x.x) || isinf(x.x), isnan(x.y) || isinf(x.y), isnan(x.z) || isinf(x.z));
    return mix(x, vec3(0.0), bad);
}

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.count) {
        return;
    }
    vec3 g[3] = vec3[3](vec3(0.0), vec3(0.0), vec3(0.0));
    for (uint k = offsets.data[v]; k < offsets.data[v + 1u]; ++k) {
        vec4 w = weights.data[k];
        vec3 x = max(exitance(floatBitsToUint(w.w)), vec3(0.0));
        g[0] += w.xyz * x.r;
        g[1] += w.xyz * x.g;
        g[2] += w.xyz * x.b;
    }
    vec3 d = pc.factor * diffusion.data[v].rgb;
    for (uint c = 0u; c < 3u; ++c) {
        vec3 out_c = clean(d[c] * g[c]);
        uint base = v * 9u + 3u * c;
        gradient.data[base] = out_c.x;
        gradient.data[base + 1u] = out_c.y;
        gradient.data[base + 2u] = out_c.z;
    }
}
