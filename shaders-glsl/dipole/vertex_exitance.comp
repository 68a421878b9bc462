#version 460
// Dipole method, per display vertex (Mertens et al. 2003, section 3.2: "averaged at the vertices
// for Gouraud shading"): the area-weighted mean of the exitance of the triangles around the
// vertex, times its texture factor (1 unless the material is texture-only), times `scale`.
// Writes rgb at floats [v * stride + offset, +3) of `vertex_exitance`: stride 4, offset 0, scale 1
// for the pass's own vec4 buffer of radiant exitance M; or the display mesh's interleaved Vertex
// (its exitance field, J+ = M / (1 - F_dr): scale 1 / (1 - F_dr)) in place.
layout(local_size_x = 64) in;

struct VertexFace {
    uint face;
    float weight;
};
layout(set = 0, binding = 0, std430) readonly buffer NodeExitance { vec4 values[]; } node_exitance;
layout(set = 0, binding = 1, std430) readonly buffer VertexFaceOffsets { uint values[]; } vertex_face_offsets;
layout(set = 0, binding = 2, std430) readonly buffer VertexFaces { VertexFace values[]; } vertex_faces;
layout(set = 0, binding = 3, std430) readonly buffer VertexModulation { vec4 values[]; } vertex_modulation;
layout(set = 0, binding = 4, std430) writeonly buffer VertexExitance { float values[]; } vertex_exitance;

layout(push_constant) uniform VertexPush {
    uint vertex_count;
    uint stride;
    uint offset;
    float scale;
} pc;

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.vertex_count) {
        return;
    }
    vec3 m = vec3(0.0);
    uint end = vertex_face_offsets.values[v + 1u];
    for (uint k = vertex_face_offsets.values[v]; k < end; ++k) {
        VertexFace f = vertex_faces.values[k];
        m += f.weight * node_exitance.values[f.face].rgb;
    }
    m *= vertex_modulation.values[v].rgb * pc.scale;
    uint base = v * pc.stride + pc.offset;
    vertex_exitance.values[base] = m.r;
    vertex_exitance.values[base + 1u] = m.g;
    vertex_exitance.values[base + 2u] = m.b;
}
