#version 460
// Solid voxelization, step 3 (solver::voxel::VoxelizePass): a voxel is solid when enough axes
// voted it inside (2 of 3 by default: robust to a hole crossed by one axis's column), and gets the
// medium the relaxation reads: rgb the per-mm edge cost coefficient of the model (paper: the
// reduced extinction sigma_t' = sigma_s' + sigma_a; diffusion: the effective transport coefficient
// sigma_tr = sqrt(3 sigma_a sigma_t')), sampled trilinearly from the material volume at the voxel
// centre; a = 1 solid, 0 empty.
#include "voxel_grid.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(set = 0, binding = 0, std430) readonly buffer Votes { uint values[]; } votes;
layout(set = 0, binding = 1, std430) readonly buffer Grid { GridFrame grid; } grid;
layout(set = 0, binding = 2) uniform sampler3D sigma_s_volume;
layout(set = 0, binding = 3) uniform sampler3D sigma_a_volume;
layout(set = 0, binding = 4, rgba32f) uniform writeonly image3D medium;
// rgb: D = 1 / (3 sigma_t') per channel, for the diffusion model's exit profile (a placeholder
// for the paper model, not written).
layout(set = 0, binding = 5, rgba32f) uniform writeonly image3D transport;

layout(push_constant) uniform ClassifyPush {
    uvec4 dims;          // xyz: voxels per axis
    vec4 material_lo;    // xyz: the material volume's box (mm, object frame)
    vec4 material_hi;
    uint votes_needed;   // axes that must vote inside
    uint model;          // 0: paper (sigma_t'), 1: diffusion (sigma_tr)
    uint pad0;
    uint pad1;
} pc;

void main() {
    ivec3 v = ivec3(gl_GlobalInvocationID);
    if (!in_grid(v, pc.dims.xyz)) {
        return;
    }
    GridFrame g = grid.grid;
    bool solid = votes.values[voxel_index(v, pc.dims.xyz)] >= pc.votes_needed;
    vec4 value = vec4(0.0);
    vec3 diffusion = vec3(0.0);
    if (solid) {
        vec3 extent = max(pc.material_hi.xyz - pc.material_lo.xyz, vec3(1e-30));
        vec3 uvw = clamp((voxel_centre(v, g) - pc.material_lo.xyz) / extent, 0.0, 1.0);
        vec3 sigma_s = max(texture(sigma_s_volume, uvw).rgb, vec3(0.0));
        vec3 sigma_a = max(texture(sigma_a_volume, uvw).rgb, vec3(0.0));
        vec3 sigma_t = sigma_s + sigma_a;
        vec3 cost = pc.model == 0u ? sigma_t : sqrt(3.0 * sigma_a * sigma_t);
        value = vec4(cost, 1.0);
        diffusion = vec3(
            sigma_t.r > 0.0 ? 1.0 / (3.0 * sigma_t.r) : 0.0,
            sigma_t.g > 0.0 ? 1.0 / (3.0 * sigma_t.g) : 0.0,
            sigma_t.b > 0.0 ? 1.0 / (3.0 * sigma_t.b) : 0.0);
    }
    imageStore(medium, v, value);
    if (pc.model == 1u) {
        imageStore(transport, v, vec4(diffusion, 0.0));
    }
}
