#version 460
// Per display-mesh vertex J+ (DESIGN section 3 step 9): the clamped surface-node J+ interpolated
// with the vertex's Shepard shading weights (links already turned into linear texel indices of the
// finest level). Writes one vec4 per vertex (rgb = J+, a = 1), the vertex-J+ input of the mesh pass.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D j_plus;
layout(set = 0, binding = 1, std430) readonly buffer VertexLinks { uvec4 links[]; } vertex_links;
layout(set = 0, binding = 2, std430) readonly buffer VertexWeights { vec4 weights[]; } vertex_weights;
layout(set = 0, binding = 3, std430) writeonly buffer VertexJPlus { vec4 values[]; } vertex_j_plus;

layout(push_constant) uniform VertexPush {
    uint count;
    uint width;
} pc;

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.count) {
        return;
    }
    uvec4 l = vertex_links.links[v];
    vec4 w = vertex_weights.weights[v];
    vec3 acc = vec3(0.0);
    for (int k = 0; k < 4; ++k) {
        ivec2 t = ivec2(int(l[k] % pc.width), int(l[k] / pc.width));
        acc += w[k] * imageLoad(j_plus, t).rgb;
    }
    vertex_j_plus.values[v] = vec4(acc, 1.0);
}
