#version 460
// Final shading (DESIGN section 5): L_o = F_t(eta, theta_o) (g(mu_i) J+ + X) / (pi eta^2) (physical)
// or F_t (g J+ + X) / pi (paper Eq. 4), X the single scattering per vertex (DESIGN 2.8), g the exit
// lobe of the diffusion (scene::ExitLobe, 1 for Lambert), plus optional
// Cook-Torrance specular of one light, shadowed by the
// light's tile of the shadow atlas (light_view_proj maps onto the whole atlas), plus the mirror
// reflection of the environment F_r(eta, theta_o) L_env(r).
#include "optics.glsl"

// render::MAX_LIGHTS (ShadeUniforms' size is checked against this block's reflection).
#define MAX_LIGHTS 8
// scene::own_lobe::GAUSS_NODES / GAUSS_WEIGHTS: 8-point Gauss-Legendre on [0, 1].
const float GAUSS_NODES[8] = float[8](0.019855072, 0.10166676, 0.23723380, 0.40828268,
                                      0.59171732, 0.76276620, 0.89833324, 0.98014493);
const float GAUSS_WEIGHTS[8] = float[8](0.050614268, 0.11119052, 0.15685332, 0.18134189,
                                        0.18134189, 0.15685332, 0.11119052, 0.050614268);

layout(location = 0) in vec3 v_position;
layout(location = 1) in vec3 v_normal;
layout(location = 2) in vec3 v_exitance;
layout(location = 3) in vec3 v_scattered;
layout(location = 4) in float v_share;
// f D grad X per channel at the vertices, interpolated (frame::TangentialPass; tangential.w 2).
layout(location = 5) in vec3 v_gradient_r;
layout(location = 6) in vec3 v_gradient_g;
layout(location = 7) in vec3 v_gradient_b;
// The exitance the method wrote before the bounce added to it (frame::Method::exit_share's rgb;
// read with pc.lobe_bounce).
layout(location = 8) in vec3 v_before_bounce;

layout(set = 0, binding = 0) uniform ShadeUniforms {
    mat4 view_proj;
    mat4 light_view_proj;
    vec4 camera_pos;
    vec4 light_dir;
    vec4 light_irradiance;
    // Environment radiance as order-2 real SH (rgb; solver::Environment's basis and order), for
    // its mirror reflection; all zero when there is no environment or no specular.
    vec4 env_sh[9];
    // The own-light lobe (scene::own_lobe, scene::ExitLobe::Chandra): rgb the albedo, w 1 where
    // it applies; per light 3 vec4 (render::mesh_pass::own_light_uniforms): (direction to it or
    // position, kind 0 none / 1 directional / 2 point / 3 spot), (rgb, spot cos inner), (spot
    // axis, spot cos outer); the environment's radiance SH (its irradiance: a Lambertian part).
    vec4 own_albedo;
    vec4 own_lights[3 * MAX_LIGHTS];
    vec4 own_env_sh[9];
    // The diffusion's tangential flux (scene::tangential_flux, render --tangential-flux): rgb
    // 3 D phi / (4 X eta) per channel (transport::Boundary::tangential_flux_factor times D), w 1
    // where it applies.
    vec4 tangential;
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
    // 1: the lobe shapes the method's exitance v_before_bounce only; what the bounce added (light
    // that arrived diffusely from the surface elsewhere) leaves Lambertian
    // (scene::ExitLobe::with_bounce).
    uint lobe_bounce;
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

// Chandrasekhar's H for isotropic scattering, Hapke's approximation (Icarus 157, 2002, eq. 13;
// scene::own_lobe::h_function), per channel.
vec3 h_function(float x, vec3 omega) {
    x = clamp(x, 1e-6, 1.0);
    vec3 g = sqrt(max(1.0 - omega, vec3(0.0)));
    vec3 r0 = (1.0 - g) / (1.0 + g);
    return 1.0 / (1.0 - omega * x * (r0 + 0.5 * (1.0 - 2.0 * r0 * x) * log((1.0 + x) / x)));
}

// The own-light lobe g(mu; mu0, omega) = (H(mu) H(mu0) - 1) / (mu + mu0), normalized to
// 2 int g mu dmu = 1 (scene::own_lobe::own_lobe; Chandrasekhar 1950, ch. IV eq. 31 less its
// single scattering). h_nodes: H at the Gauss nodes, h_mu: H at the view cosine.
vec3 own_lobe(float mu, float mu0, vec3 omega, vec3 h_nodes[8], vec3 h_mu) {
    mu0 = clamp(mu0, 0.0, 1.0);
    vec3 h0 = h_function(mu0, omega);
    vec3 norm = vec3(0.0);
    for (int j = 0; j < 8; j++) {
        float x = GAUSS_NODES[j];
        norm += GAUSS_WEIGHTS[j] * x * (h_nodes[j] * h0 - 1.0) / (x + mu0);
    }
    norm *= 2.0;
    vec3 g = (h_mu * h0 - 1.0) / max(mu + mu0, 1e-6) / max(norm, vec3(1e-30));
    // No multiple scattering (norm 0): Lambert.
    return mix(vec3(1.0), max(g, vec3(0.0)), greaterThan(norm, vec3(0.0)));
}

// The environment's irradiance at normal n from its radiance SH (scene::Environment::irradiance).
vec3 sh_irradiance(vec3 n) {
    const float C1 = 0.429043, C2 = 0.511664, C3 = 0.743125, C4 = 0.886227, C5 = 0.247708;
    vec3 e = C1 * frame.own_env_sh[8].rgb * (n.x * n.x - n.y * n.y)
        + C3 * frame.own_env_sh[6].rgb * n.z * n.z + C4 * frame.own_env_sh[0].rgb
        - C5 * frame.own_env_sh[6].rgb
        + 2.0 * C1 * (frame.own_env_sh[4].rgb * n.x * n.y + frame.own_env_sh[7].rgb * n.x * n.z
                      + frame.own_env_sh[5].rgb * n.y * n.z)
        + 2.0 * C2 * (frame.own_env_sh[3].rgb * n.x + frame.own_env_sh[1].rgb * n.y
                      + frame.own_env_sh[2].rgb * n.z);
    return max(e, vec3(0.0));
}

// The own light's factor on the Lambertian radiance toward view cosine mu at x, normal n
// (scene::own_lobe::OwnLight): each light's lobe weighted by its irradiance E mu0 (no shadow
// test), the environment's Lambertian; 1 where nothing lights the point.
vec3 own_light_factor(vec3 x, vec3 n, float mu) {
    vec3 omega = clamp(frame.own_albedo.rgb, 0.0, 1.0);
    vec3 h_nodes[8];
    for (int j = 0; j < 8; j++) {
        h_nodes[j] = h_function(GAUSS_NODES[j], omega);
    }
    vec3 h_mu = h_function(mu, omega);
    vec3 weight = sh_irradiance(n);
    vec3 sum = weight;
    for (int i = 0; i < MAX_LIGHTS; i++) {
        vec4 a = frame.own_lights[3 * i];
        vec4 b = frame.own_lights[3 * i + 1];
        vec4 c = frame.own_lights[3 * i + 2];
        vec3 l;
        vec3 e = b.rgb;
        if (a.w == 1.0) {
            l = a.xyz;
        } else if (a.w >= 2.0) {
            vec3 v = a.xyz - x;
            float r = max(length(v), 1e-9);
            l = v / r;
            e /= r * r;
            if (a.w == 3.0) {
                // scene::Light::arriving's cone: smoothstep in cos from outer to inner.
                float cos_axis = dot(-l, c.xyz);
                float t = b.w - c.w > 1e-12 ? clamp((cos_axis - c.w) / (b.w - c.w), 0.0, 1.0)
                                            : (cos_axis >= c.w ? 1.0 : 0.0);
                e *= t * t * (3.0 - 2.0 * t);
            }
        } else {
            continue;
        }
        float mu0 = dot(n, l);
        if (mu0 <= 0.0) {
            continue;
        }
        vec3 w = max(e, vec3(0.0)) * mu0;
        sum += w * own_lobe(mu, mu0, omega, h_nodes, h_mu);
        weight += w;
    }
    return mix(vec3(1.0), sum / max(weight, vec3(1e-30)), greaterThan(weight, vec3(0.0)));
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
    float node = (1.0 + b * mu_i) / (1.0 + b * pc.lobe_k);
    vec3 lobe = vec3(node);
    if (frame.own_albedo.w > 0.0) {
        // ExitLobe::Chandra (eta 1, mu_i = n_v): the own part (1 - s) drawn with the own light's
        // shape instead of Lambert, node + (1 - s) (g_own - 1) (scene::ExitLobe::factor_lit).
        float s = clamp(v_share, 0.0, 1.0);
        lobe = max(node + (1.0 - s) * (own_light_factor(v_position, n, n_v) - 1.0), vec3(0.0));
    }
    if (pc.lobe_bounce != 0u) {
        // The bounce's part of the exitance is light that re-entered from the hemisphere the
        // surface sees: own light under diffuse incidence, whose multiple-scattered reflection
        // is flat (Chandrasekhar's isotropic illumination; scene::ExitLobe::with_bounce).
        vec3 x = max(v_exitance, vec3(0.0));
        vec3 solved = clamp(v_before_bounce, vec3(0.0), x);
        vec3 w = mix(vec3(1.0), solved / max(x, vec3(1e-30)), greaterThan(x, vec3(0.0)));
        lobe = w * lobe + (1.0 - w);
    }
    vec3 diffused = lobe * max(v_exitance, vec3(0.0));
    // The tangential flux J_t = -D grad_t phi of the diffusion (P1: L = (phi + 3 J . w) / (4 pi)
    // inside): toward the view, -3 D grad_t X . w_t phi / (4 X eta) of the Lambertian radiance
    // (the refracted w_t is w_t / eta); the lobes above draw only the normal flux. Light flowing
    // from a lit cap to its terminator leaves brighter toward the dark side, darker toward the
    // lit one (benches/RESULTS.md, "The front-lit spheres, term by term"). grad_t X from the
    // screen derivatives of the interpolated exitance and position (Mikkelsen's surface
    // gradient): the triangle's own gradient, the fallback where no per-vertex gradient exists
    // (w 1; w 2: the smooth per-vertex stream above). Derivatives in uniform control flow.
    vec3 dpx = dFdx(v_position);
    vec3 dpy = dFdy(v_position);
    vec3 dxx = dFdx(v_exitance);
    vec3 dxy = dFdy(v_exitance);
    if (frame.tangential.w > 1.5) {
        // The smooth path: the vertices' gradients (each the area-weighted mean of its
        // triangles'), interpolated and projected onto the tangent plane (. v = . w_t there).
        vec3 vt = v - n * dot(n, v);
        diffused -= vec3(dot(v_gradient_r, vt), dot(v_gradient_g, vt), dot(v_gradient_b, vt));
    } else if (frame.tangential.w > 0.0) {
        vec3 r1 = cross(dpy, n);
        vec3 r2 = cross(n, dpx);
        float det = dot(dpx, r1);
        if (abs(det) > 1e-20) {
            // grad_t X . v per channel (grad_t X lies in the tangent plane: . v = . w_t).
            vec3 along = (dxx * dot(r1, v) + dxy * dot(r2, v)) / det;
            diffused -= frame.tangential.rgb * along;
        }
    }
    // Single scattering (DESIGN 2.8) joins the diffusion's J+: L_ss = T_o X / (pi eta^2). As a
    // difference to the flat closed form it may be negative; the sum never is.
    vec3 radiance = f_t * max(diffused + v_scattered, vec3(0.0)) * scale;
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
