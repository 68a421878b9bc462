#version 460
// Solid voxelization, step 2 of 3 per axis (solver::voxel::VoxelizePass): one invocation per
// column along `axis` sums the crossings (rasterize_crossings.comp) from the low end; a voxel whose
// winding number is non-zero is inside by this axis's vote. Each axis adds one vote, so a column
// that passes through a hole of the mesh (one crossing missing: the rest of the column flips) is
// outvoted by the other two axes, whose columns through that voxel usually miss the hole.
#include "voxel_grid.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, std430) readonly buffer Crossings { int counts[]; } crossings;
layout(set = 0, binding = 1, std430) buffer Votes { uint values[]; } votes;

layout(push_constant) uniform VotePush {
    uvec4 dims;  // xyz: voxels per axis
    uint axis;   // the column direction
    uint pad0;
    uint pad1;
    uint pad2;
} pc;

void main() {
    uint a = pc.axis;
    uint u = (a + 1u) % 3u;
    uint v = (a + 2u) % 3u;
    uvec2 column = gl_GlobalInvocationID.xy;
    if (column.x >= pc.dims[u] || column.y >= pc.dims[v]) {
        return;
    }
    int winding = 0;
    ivec3 voxel;
    voxel[u] = int(column.x);
    voxel[v] = int(column.y);
    for (int k = 0; k < int(pc.dims[a]); ++k) {
        voxel[a] = k;
        uint i = voxel_index(voxel, pc.dims.xyz);
        winding += crossings.counts[i];
        if (winding != 0) {
            votes.values[i] += 1u;
        }
    }
}
