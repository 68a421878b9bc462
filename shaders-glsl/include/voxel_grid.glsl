// The voxel method's grid (solver::voxel, DESIGN section 6): dims fixed at creation, origin and
// voxel size h fitted to the mesh's bounds on the GPU every frame (voxel/fit_grid.comp), so a
// deforming or fractured mesh needs nothing from the CPU. Voxel (x, y, z) has its centre at
// origin + (x + 0.5, y + 0.5, z + 0.5) h and linear index x + dims.x (y + dims.y z).
#ifndef VOXEL_GRID_GLSL
#define VOXEL_GRID_GLSL

struct GridFrame {
    vec4 origin;  // xyz: corner of voxel (0, 0, 0) in mm; w: voxel size h in mm
    vec4 lo;      // xyz: the mesh's bounds this frame (min); w: finite vertices counted
    vec4 hi;      // xyz: bounds (max); w: unused
    uvec4 dims;   // xyz: voxels per axis; w: voxel count
};

// Unreached / unlit optical depth: finite (no Inf leaves a pass), exp(-N_UNLIT) = 0, and
// N_UNLIT + any edge cost rounds back to N_UNLIT.
const float N_UNLIT = 1e30;

// Edge lengths in units of h of the 26-neighbourhood: 1, sqrt(2), sqrt(3) (the f32 values the CPU
// reference uses: solver::voxel::cpu::EDGE_FACTORS).
const float SQRT2 = 1.41421356;
const float SQRT3 = 1.73205081;

uint voxel_index(ivec3 v, uvec3 dims) {
    return uint(v.x) + dims.x * (uint(v.y) + dims.y * uint(v.z));
}

ivec3 voxel_coord(uint i, uvec3 dims) {
    return ivec3(int(i % dims.x), int((i / dims.x) % dims.y), int(i / (dims.x * dims.y)));
}

bool in_grid(ivec3 v, uvec3 dims) {
    return all(greaterThanEqual(v, ivec3(0))) && all(lessThan(v, ivec3(dims)));
}

vec3 voxel_centre(ivec3 v, GridFrame g) {
    return g.origin.xyz + (vec3(v) + 0.5) * g.origin.w;
}

// Length factor of offset o (each component in -1..1): 1, sqrt2 or sqrt3.
float edge_factor(ivec3 o) {
    int k = abs(o.x) + abs(o.y) + abs(o.z);
    return k == 1 ? 1.0 : (k == 2 ? SQRT2 : SQRT3);
}

#endif
