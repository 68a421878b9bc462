// Shared by the relaxation passes (solver::voxel::RelaxPass): the change counter the control pass
// turns into indirect dispatch arguments, and the edge cost of paper section 2.1.
#ifndef RELAX_COMMON_GLSL
#define RELAX_COMMON_GLSL

struct RelaxControl {
    uint groups_x;    // VkDispatchIndirectCommand of the Jacobi iterations
    uint groups_y;
    uint groups_z;
    uint iterations;  // iterations (Jacobi) or sweeps (sweeping) run
    uint blocks;      // control decisions taken while running
    uint changed;     // workgroups that changed a value since the last decision
    uint converged;   // 1 once a block (round) changed nothing
    uint pad;
    uvec4 sweep_x;    // xyz: VkDispatchIndirectCommand of a sweep slice along x; w unused
    uvec4 sweep_y;
    uvec4 sweep_z;
};

// The cost of the edge between voxels with per-mm coefficients a and b, `len` mm long: the mean
// coefficient times the length (the trapezoid rule along the edge). `precise`: no contraction into
// fma, so the CPU reference (solver::voxel::cpu) repeats it bit for bit.
vec3 edge_cost(vec3 a, vec3 b, float len) {
    precise vec3 mean = (a + b) * 0.5;
    precise vec3 cost = mean * len;
    return cost;
}

#endif
