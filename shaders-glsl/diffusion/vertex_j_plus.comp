#version 460
// Per display-mesh vertex J+ (DESIGN section 3 step 9): the clamped surface-node J+ interpolated
// with the vertex's Shepard shading weights (links already turned into linear texel indices of the
// finest level). Writes rgb J+ at floats [v * stride + offset, +3) of `vertex_j_plus`: stride 4 for
// the solver's own vec4 buffer, or the mesh pass's interleaved Vertex (exitance field) in place.
// With `share` set, the nodes' diffused share (the J+ image's alpha) at float base + 3 too (the
// per-node exit lobe's vertex stream: the solver's own buffer).
layout(local_size_x = 64) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D j_plus;
layout(set = 0, binding = 1, std430) readonly buffer VertexLinks { uvec4 links[]; } vertex_links;
layout(set = 0, binding = 2, std430) readonly buffer VertexWeights { vec4 weights[]; } vertex_weights;
layout(set = 0, binding = 3, std430) writeonly buffer VertexJPlus { float values[]; } vertex_j_plus;

layout(push_constant) uniform VertexPush {
    uint count;
    uint width;
    uint stride;
    uint offset;
    uint share;
} pc;

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.count) {
        return;
    }
    uvec4 l = vertex_links.links[v];
    vec4 w = vertex_weights.weights[v];
    vec4 acc = vec4(0.0);
    for (int k = 0; k < 4; ++k) {
        ivec2 t = ivec2(int(l[k] % pc.width), int(l[k] / pc.width));
        acc += w[k] * imageLoad(j_plus, t);
    }
    uint base = v * pc.stride + pc.offset;
    vertex_j_plus.values[base] = acc.r;
    vertex_j_plus.values[base + 1u] = acc.g;
    vertex_j_plus.values[base + 2u] = acc.b;
    if (pc.share != 0u) {
        vertex_j_plus.values[base + 3u] = clamp(acc.a, 0.0, 1.0);
    }
}
