#version 460
// Exitance at the display mesh's vertices (paper section 2.2; solver::voxel::ExitPass): the
// radiance volume read with trilinear filtering at each vertex, divided by the filtered coverage
// (only solid voxels count); where none of the 8 is solid (a part thinner than the voxels), the mean
// of the solid voxels among the 27 around the vertex; else 0. Writes
//   exitance[v] = vec4(M, covered)   M = (1 - F_dr) J+, the radiant exitance leaving into air
// (the method seam's output: the shading applies the angular lobe), and optionally, for the
// shading pass of today that reads J+, J+ = M / (1 - F_dr) into the mesh's Vertex exitance field.
#include "voxel_grid.glsl"
#include "optics.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, std430) readonly buffer Vertices { float values[]; } vertices;
layout(set = 0, binding = 1, std430) readonly buffer Grid { GridFrame grid; } grid;
layout(set = 0, binding = 2) uniform sampler3D exit_volume;
layout(set = 0, binding = 3, std430) writeonly buffer Exitance { vec4 values[]; } exitance;
layout(set = 0, binding = 4, std430) writeonly buffer MeshExitance { float values[]; } mesh_exitance;

layout(push_constant) uniform VertexExitPush {
    uint count;
    uint stride;       // floats per vertex in `vertices` (and `mesh_exitance`)
    uint mesh_offset;  // float offset of the exitance field in a vertex
    uint write_mesh;   // 1: also write J+ into mesh_exitance
    float eta;
    float pad0;
    float pad1;
    float pad2;
} pc;

// Coverage below this is no solid voxel among the 8 (the filter's weights are >= 1/256 each on
// hardware with 8-bit filtering fractions).
const float MIN_COVERAGE = 1e-3;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    GridFrame g = grid.grid;
    uvec3 dims = g.dims.xyz;
    uint b = i * pc.stride;
    vec3 p = vec3(vertices.values[b], vertices.values[b + 1u], vertices.values[b + 2u]);
    vec3 j = vec3(0.0);
    float covered = 0.0;
    if (!(any(isnan(p)) || any(isinf(p)))) {
        vec3 uvw = (p - g.origin.xyz) / (g.origin.w * vec3(dims));
        vec4 s = texture(exit_volume, uvw);
        if (s.a > MIN_COVERAGE) {
            j = s.rgb / s.a;
            covered = 1.0;
        } else {
            ivec3 c = ivec3(floor((p - g.origin.xyz) / g.origin.w));
            vec3 sum = vec3(0.0);
            float count = 0.0;
            for (int z = -1; z <= 1; ++z) {
                for (int y = -1; y <= 1; ++y) {
                    for (int x = -1; x <= 1; ++x) {
                        ivec3 u = c + ivec3(x, y, z);
                        if (!in_grid(u, dims)) {
                            continue;
                        }
                        vec4 t = texelFetch(exit_volume, u, 0);
                        if (t.a > 0.0) {
                            sum += t.rgb;
                            count += 1.0;
                        }
                    }
                }
            }
            if (count > 0.0) {
                j = sum / count;
                covered = 1.0;
            }
        }
    }
    if (any(isnan(j)) || any(isinf(j))) {
        j = vec3(0.0);
        covered = 0.0;
    }
    float f_dr = diffuse_reflectance(pc.eta);
    exitance.values[i] = vec4((1.0 - f_dr) * j, covered);
    if (pc.write_mesh != 0u) {
        uint m = i * pc.stride + pc.mesh_offset;
        mesh_exitance.values[m] = j.r;
        mesh_exitance.values[m + 1u] = j.g;
        mesh_exitance.values[m + 2u] = j.b;
    }
}
