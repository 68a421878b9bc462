#version 460
// Final shading, vertex stage: world position, normal and the per-vertex exitance J+.
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in vec3 exitance;
// Single scattering X per vertex (DESIGN 2.8; frame::SingleScatteringPass, zero while off).
layout(location = 3) in vec4 scattered;
// The per-node exit lobe's stream (frame::Method::exit_share): a the diffused share (0 when the
// method has none), rgb the exitance the method wrote before the bounce added to it (the
// QuadGraph solver's own vertex J+; read only with ShadePush::lobe_bounce).
layout(location = 4) in vec4 share;
// The tangential flux's f D grad X per channel (frame::TangentialPass; unread without it).
layout(location = 5) in vec3 gradient_r;
layout(location = 6) in vec3 gradient_g;
layout(location = 7) in vec3 gradient_b;

layout(set = 0, binding = 0) uniform ShadeUniforms {
    mat4 view_proj;
    mat4 light_view_proj;
    vec4 camera_pos;
    vec4 light_dir;        // xyz: direction the light travels (unit); w: 1 if there is a light
    vec4 light_irradiance; // rgb: irradiance on a surface facing the light
    vec4 env_sh[9];        // environment radiance, order-2 SH (fragment stage only)
    // The own-light lobe's albedo, lights and environment (fragment stage only; shade_mesh.frag;
    // 3 vec4 per light, render::MAX_LIGHTS = 8).
    vec4 own_albedo;
    vec4 own_lights[24];
    vec4 own_env_sh[9];
    vec4 tangential; // the tangential flux's factor per channel (fragment stage only)
} frame;

layout(location = 0) out vec3 v_position;
layout(location = 1) out vec3 v_normal;
layout(location = 2) out vec3 v_exitance;
layout(location = 3) out vec3 v_scattered;
layout(location = 4) out float v_share;
layout(location = 5) out vec3 v_gradient_r;
layout(location = 6) out vec3 v_gradient_g;
layout(location = 7) out vec3 v_gradient_b;
layout(location = 8) out vec3 v_before_bounce;

void main() {
    v_position = position;
    v_normal = normal;
    v_exitance = exitance;
    v_scattered = scattered.rgb;
    v_share = share.a;
    v_before_bounce = share.rgb;
    v_gradient_r = gradient_r;
    v_gradient_g = gradient_g;
    v_gradient_b = gradient_b;
    gl_Position = frame.view_proj * vec4(position, 1.0);
}
