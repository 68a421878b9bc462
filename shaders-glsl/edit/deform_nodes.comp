#version 460
#extension GL_GOOGLE_include_directive : require
// Deformation, step 2: every node of a level at its barycentric coordinates in its rest
// tetrahedron (inner node: its own tetrahedron; surface node: the one it sits on, coordinates
// possibly outside [0, 1]): exact for affine maps, piecewise affine otherwise. Surface nodes also
// get their normal through the tetrahedron's F^-T and are written where the irradiance gather
// reads them (surface_position, surface_normal).
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, std430) readonly buffer Cells { uint data[]; } cells;
layout(set = 0, binding = 1, std430) readonly buffer Bary { vec4 data[]; } bary;
layout(set = 0, binding = 2, std430) readonly buffer RestNormals { vec4 data[]; } rest_normals;
layout(set = 0, binding = 3, std430) readonly buffer Tets { uvec4 data[]; } tets;
layout(set = 0, binding = 4, std430) readonly buffer RestVertices { vec4 data[]; } rest;
layout(set = 0, binding = 5, std430) readonly buffer Vertices { vec4 data[]; } vertices;
layout(set = 0, binding = 6, std430) writeonly buffer NodePositions { vec4 data[]; } node_pos;
layout(set = 0, binding = 7, rgba32f) uniform writeonly image2D surface_position;
layout(set = 0, binding = 8, rgba16f) uniform writeonly image2D surface_normal;

layout(push_constant) uniform NodesPush {
    ivec2 size;
    uint width;
    uint surface_rows;
} pc;

#include "deform_common.glsl"

const uint NO_CELL = 0xffffffffu;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    uint t = uint(p.y) * pc.width + uint(p.x);
    uint cell = cells.data[t];
    if (cell == NO_CELL) {
        node_pos.data[t] = vec4(0.0);
        return;
    }
    bool surface = uint(p.y) < pc.surface_rows;
    uvec4 tet = tets.data[surface ? cell >> 2 : cell];
    vec3 d0 = vertices.data[tet.x].xyz;
    vec3 d1 = vertices.data[tet.y].xyz;
    vec3 d2 = vertices.data[tet.z].xyz;
    vec3 d3 = vertices.data[tet.w].xyz;
    vec4 b = bary.data[t];
    vec3 x = b.x * d0 + b.y * d1 + b.z * d2 + b.w * d3;
    node_pos.data[t] = vec4(x, 1.0);
    if (surface) {
        vec3 n = transform_normal(rest.data[tet.x].xyz, rest.data[tet.y].xyz, rest.data[tet.z].xyz,
                                  rest.data[tet.w].xyz, d0, d1, d2, d3, rest_normals.data[t].xyz);
        imageStore(surface_position, p, vec4(x, 1.0));
        imageStore(surface_normal, p, vec4(n, 0.0));
    }
}
