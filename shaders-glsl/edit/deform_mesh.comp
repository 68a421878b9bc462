#version 460
#extension GL_GOOGLE_include_directive : require
// Deformation, step 4: the display / shadow-caster mesh vertices at their barycentric coordinates
// in a rest tetrahedron of the finest level (the one under the vertex's first shading link), with
// normals through that tetrahedron's F^-T. Written in the interleaved render::Vertex layout
// (9 floats: position, normal, exitance; exitance left alone), then copied into each mesh.
layout(local_size_x = 64) in;

struct MeshVertex {
    vec4 bary;
    vec4 normal;
    uvec4 tet;
};

layout(set = 0, binding = 0, std430) readonly buffer MeshMap { MeshVertex data[]; } map;
layout(set = 0, binding = 1, std430) readonly buffer Tets { uvec4 data[]; } tets;
layout(set = 0, binding = 2, std430) readonly buffer RestVertices { vec4 data[]; } rest;
layout(set = 0, binding = 3, std430) readonly buffer Vertices { vec4 data[]; } vertices;
layout(set = 0, binding = 4, std430) writeonly buffer MeshOut { float data[]; } values;

layout(push_constant) uniform MeshPush {
    uint count;
} pc;

#include "deform_common.glsl"

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.count) {
        return;
    }
    MeshVertex m = map.data[v];
    uvec4 tet = tets.data[m.tet.x];
    vec3 d0 = vertices.data[tet.x].xyz;
    vec3 d1 = vertices.data[tet.y].xyz;
    vec3 d2 = vertices.data[tet.z].xyz;
    vec3 d3 = vertices.data[tet.w].xyz;
    vec3 x = m.bary.x * d0 + m.bary.y * d1 + m.bary.z * d2 + m.bary.w * d3;
    vec3 n = transform_normal(rest.data[tet.x].xyz, rest.data[tet.y].xyz, rest.data[tet.z].xyz, rest.data[tet.w].xyz,
                              d0, d1, d2, d3, m.normal.xyz);
    uint base = v * 9u;
    values.data[base + 0u] = x.x;
    values.data[base + 1u] = x.y;
    values.data[base + 2u] = x.z;
    values.data[base + 3u] = n.x;
    values.data[base + 4u] = n.y;
    values.data[base + 5u] = n.z;
}
