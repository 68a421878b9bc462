#version 460
// Reflective shadow map (solver::voxel::rsm, Dachsbacher and Stamminger 2005), vertex stage: the
// mesh seen from one light view (a tile of the atlas; the same views as render::ShadowMaps).
#include "rsm_view.glsl"

layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;

layout(set = 0, binding = 0, std430) readonly buffer RsmViews { RsmView views[RSM_MAX_VIEWS]; } rsm;

layout(push_constant) uniform RsmPush {
    uint view;
    float eta;
    float min_cos;
    float pad;
} pc;

layout(location = 0) out vec3 v_position;
layout(location = 1) out vec3 v_normal;

void main() {
    v_position = position;
    v_normal = normal;
    gl_Position = rsm.views[pc.view].view_proj * vec4(position, 1.0);
}
