#version 460
// The relaxation's stopping rule, decided on the GPU (solver::voxel::RelaxPass; as the QuadGraph
// solve's convergence pass): after each block of k Jacobi iterations (or each sweep round), one
// thread counts the block and, if no workgroup changed a value in it, zeroes the indirect dispatch
// arguments of every later block: the recorded iterations after that cost an empty dispatch each.
// No CPU read-back inside a frame; `iterations` is read afterwards.
#include "relax_common.glsl"

layout(local_size_x = 1) in;

layout(set = 0, binding = 0, std430) buffer Control { RelaxControl control; } control;

layout(push_constant) uniform ControlPush {
    uint k;  // iterations (or sweeps) per block
    uint pad0;
    uint pad1;
    uint pad2;
} pc;

void main() {
    if (control.control.converged != 0u) {
        return;
    }
    control.control.iterations += pc.k;
    control.control.blocks += 1u;
    if (control.control.changed == 0u) {
        control.control.converged = 1u;
        control.control.groups_x = 0u;
        control.control.groups_y = 0u;
        control.control.groups_z = 0u;
        control.control.sweep_x = uvec4(0u);
        control.control.sweep_y = uvec4(0u);
        control.control.sweep_z = uvec4(0u);
    }
    control.control.changed = 0u;
}
