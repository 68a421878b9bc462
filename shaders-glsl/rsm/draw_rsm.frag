#version 460
// Reflective shadow map, fragment stage: per texel of a light view, the nearest surface point
// (depth into the shared shadow atlas) and
//   position   rgb: world position (mm), a = 1 (0: no surface, the clear value)
//   normal     rgb: unit shading normal, a = mu_i = max(0, n.l)
//   irradiance rgb: E T_i, the light's irradiance on a surface facing it times the Fresnel
//              transmittance F_t(eta, theta_i) (0 facing away); a = A_perp, the texel's area
//              perpendicular to the light at the point (mm^2), so E T_i A_perp is the flux the
//              texel transmits into the object (DESIGN sections 2, 2.7, 2.8).
#include "rsm_view.glsl"
#include "optics.glsl"

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;

layout(set = 0, binding = 0, std430) readonly buffer RsmViews { RsmView views[RSM_MAX_VIEWS]; } rsm;

layout(push_constant) uniform RsmPush {
    uint view;
    float eta;
    float min_cos;
    float pad;
} pc;

layout(location = 0) out vec4 out_position;
layout(location = 1) out vec4 out_normal;
layout(location = 2) out vec4 out_irradiance;

void main() {
    RsmView view = rsm.views[pc.view];
    vec3 p = v_position;
    vec3 n = length(v_normal) > 0.0 ? normalize(v_normal) : vec3(0.0);
    vec3 l;
    vec3 e = light_arriving(view, p, l);
    float mu = max(dot(n, l), 0.0);
    vec3 transmitted = mu > 0.0 ? e * fresnel_transmittance(pc.eta, mu) : vec3(0.0);
    out_position = vec4(p, 1.0);
    out_normal = vec4(n, mu);
    out_irradiance = vec4(transmitted, texel_area(view, p));
}
