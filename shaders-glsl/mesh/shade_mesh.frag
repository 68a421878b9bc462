#version 460
// Final shading (DESIGN section 5): L_o = F_t(eta, theta_o) (g(mu_i) J+ + X) / (pi eta^2) (physical)
// or F_t (g J+ + X) / pi (paper Eq. 4), X the single scattering per vertex (DESIGN 2.8), g the exit
// lobe of the diffusion (scene::ExitLobe, 1 for Lambert), plus optional
// Cook-Torrance specular of one light, shadowed by the
// light's tile of the shadow atlas (light_view_proj maps onto the whole atlas), plus the mirror
// reflection of the environment F_r(eta, theta_o) L_env(r).
#include "optics.glsl"

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec3 v_exitance;
layout(location = 3) in vec3 v_scattered;
layout(location = 4) in float v_share;

layout(set = 0, binding = 0) uniform ShadeUniforms {
    mat4 view_proj;
    mat4 light_view_proj;
    vec4 camera_pos;
    vec4 light_dir;
    vec4 light_irradiance;
    // Environment radiance as order-2 real SH (rgb; solver::Environment's basis and order), for
    // its mirror reflection; all zero when there is no environment or no specular.
    vec4 env_sh[9];
} frame;
layout(set = 0, binding = 1) uniform sampler2DShadow shadow_map;

layout(push_constant) uniform ShadePush {
    float eta;
    uint radiance_mode; // 0: physical, 1: paper
    float roughness;    // GGX alpha = roughness^2
    uint specular;      // 1: add Cook-Torrance specular
    // Exit lobe (scene::ExitLobe::shading_push): L = L_lambert (1 + b mu_i) / (1 + b K(eta)),
    // b = lobe_slope (lobe_own + (1 - lobe_own) s), s the vertex's diffused share; 0: Lambert.
    float lobe_slope;
    float lobe_k;
    float lobe_own;
} pc;

layout(location = 0) out vec4 out_radiance;

float ggx_g1(float n_x, float a2) {
    return 2.0 * n_x / (n_x + sqrt(a2 + (1.0 - a2) * n_x * n_x));
}

// Radiance of the order-2 SH environment arriving from direction d (clamped: a truncated
// expansion can dip below zero).
vec3 sh_radiance(vec3 d) {
    vec3 l = frame.env_sh[0].rgb * 0.282095
        + 0.488603 * (frame.env_sh[1].rgb * d.y + frame.env_sh[2].rgb * d.z + frame.env_sh[3].rgb * d.x)
        + 1.092548 * (frame.env_sh[4].rgb * d.x * d.y + frame.env_sh[5].rgb * d.y * d.z
                      + frame.env_sh[7].rgb * d.x * d.z)
        + 0.315392 * frame.env_sh[6].rgb * (3.0 * d.z * d.z - 1.0)
        + 0.546274 * frame.env_sh[8].rgb * (d.x * d.x - d.y * d.y);
    return max(l, vec3(0.0));
}

void main() {
    vec3 n = normalize(v_normal);
    vec3 v = normalize(frame.camera_pos.xyz - v_position);
    float n_v = dot(n, v);
    if (n_v < 0.0) {
        // Interpolated normals can face away at silhouettes: treat as grazing.
        n_v = 0.0;
    }
    float f_t = fresnel_transmittance(pc.eta, n_v);
    float scale = pc.radiance_mode == 0u ? 1.0 / (PI * pc.eta * pc.eta) : 1.0 / PI;
    // The exit lobe (scene::ExitLobe::factor_at): mu_i the refracted cosine inside; normalized so the
    // exitance over the hemisphere is unchanged. It shapes the diffusion's J+ only: the march's X
    // is already the single scattering toward this view.
    float mu_i = sqrt(max(1.0 - (1.0 - n_v * n_v) / (pc.eta * pc.eta), 0.0));
    float b = pc.lobe_slope * (pc.lobe_own + (1.0 - pc.lobe_own) * clamp(v_share, 0.0, 1.0));
    float lobe = (1.0 + b * mu_i) / (1.0 + b * pc.lobe_k);
    // Single scattering (DESIGN 2.8) joins the diffusion's J+: L_ss = T_o X / (pi eta^2). As a
    // difference to the flat closed form it may be negative; the sum never is.
    vec3 radiance = f_t * max(lobe * max(v_exitance, vec3(0.0)) + v_scattered, vec3(0.0)) * scale;
    // The smooth boundary mirrors the environment: the part F_r = 1 - F_t of the light arriving
    // from the reflected direction (F_t above is the same unpolarized Fresnel term). The object
    // does not occlude its own reflection (exact for convex shapes).
    radiance += (1.0 - f_t) * sh_radiance(reflect(-v, n));

    if (pc.specular == 1u && frame.light_dir.w > 0.0) {
        vec3 l = -frame.light_dir.xyz;
        float n_l = dot(n, l);
        if (n_l > 0.0 && n_v > 0.0) {
            vec4 lp = frame.light_view_proj * vec4(v_position, 1.0);
            vec3 uvz = vec3(lp.xy / lp.w * 0.5 + 0.5, lp.z / lp.w);
            // A small bias keeps surfaces from shadowing themselves.
            float visible = texture(shadow_map, vec3(uvz.xy, uvz.z - 0.002));
            vec3 h = normalize(l + v);
            float a = max(pc.roughness * pc.roughness, 1e-3);
            float a2 = a * a;
            float n_h = max(dot(n, h), 0.0);
            float d = a2 / (PI * pow(n_h * n_h * (a2 - 1.0) + 1.0, 2.0));
            float g = ggx_g1(n_l, a2) * ggx_g1(n_v, a2);
            float f = fresnel_reflectance(pc.eta, max(dot(v, h), 0.0));
            radiance += visible * d * g * f / (4.0 * n_l * n_v) * frame.light_irradiance.rgb * n_l;
        }
    }
    out_radiance = vec4(radiance, 1.0);
}
