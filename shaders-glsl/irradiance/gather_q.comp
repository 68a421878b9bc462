#version 460
// Irradiance gather (DESIGN sections 2 and 5; paper Eq. 3 and section 5: "evaluating the incoming
// diffuse illumination on the surface, including shadows (using shadow mapping)" per level): for
// every surface-node texel of a level,
//   q = sum over lights of E max(0, n.l) F_t(eta, theta_l) visibility + E_env(n) (1 - F_dr,ext),
// written pre-scaled by q_scale (fp16 overflows at 65504). Visibility: 3x3 PCF in the light's
// shadow view (a tile of the depth atlas), with a normal offset of about a texel.
// With the collimated source of DESIGN 2.7 (beam.sigma_s.w = 1, homogeneous material), a light's
// transmitted beam enters as the particular solution K exp(-beta z) of the flat half-space:
// K = Q0 / (sigma_a - D beta^2), Q0 = sigma_s' E T_i mu_i / mu_t, beta = sigma_t' / mu_t. Its
// Robin right-hand side -K (1 + 2 A D beta) is written into q divided by the flux gain (so the
// solve is unchanged), and the exit query's part of it, a_phi K - a_d D beta K, into `particular`
// (added back by the J+ pass: DESIGN 2.6 with phi = phi_h + K, dphi/dz_in = phi_h' - beta K).
// Heterogeneous materials (beam_local = 1): the node's own coefficients from the level's kappa and
// mu images (sigma_t' = 1 / (3 kappa), sigma_a = mu; with Grosjean's D, beam_kappa.w = 1, the
// positive root of 3 kappa sigma_t'^2 - sigma_t' - sigma_a = 0). D is the material's diffusion
// coefficient (material::DiffusionCoefficient): 1 / (3 sigma_t') or (2 sigma_a + sigma_s') /
// (3 sigma_t'^2), in the particular solution, the resonance and the exit query alike. Second-collision source (beam_exit.w = 1,
// DESIGN 2.8's second option): Q0 times the share of once-scattered light that collides again
// (solver::transport::second_collision_ratio, the power), its decay fitted to the deep moment
// (transport::second_collision_fit: beta' = sigma_t' / mu_e), single scattering then added whole. Shadow-edge
// fallback (beam_edge = 1): a light the node's 3x3 PCF sees partly occluded enters as the boundary
// flux (the flat half-space of the particular solution fails within a mean free path of the edge).
// Continuation through a wall (beam_continuation = 1; the f64 reference's
// `Transport::continuation`, DESIGN 2.7's thin walls): a node facing away from a light gets the
// particular solution of the beam that entered on the light's side, attenuated along the refracted
// path, K exp(-beta z) at the depth z below the entry face, in its Robin row and exit query (exact
// for a slab: benches/thinwall/slab_rule.py). The entry is the surface the light's shadow view sees
// in front of the node (its depth along the light), its normal taken as -n (the wall's faces
// parallel: exact for a slab); beyond MAX_OPTICAL_DEPTH nothing arrives.
// Upstream beam (beam_upstream = 1; transport::upstream_beam, issue 12's back-lit crescent): a
// beam travels about a mean free path along a curved surface before its first collision, so with
// c = H / (eta sigma_t') (H the node's mean curvature, baked in surface_normal.w) the beam's
// incidence cosine is mu_up = mu + c (1 - mu^2) and its irradiance factor mu + c (1 - 3 mu^2),
// per channel. A node just past the terminator (mu > -UPSTREAM_SHIFT_LIMIT) tests its visibility
// a mean free path upstream, where the shadow map sees the surface lit. Off a sphere the beam
// turns by the normal curvature along its tangent t, k_t = H - |a|^2 + 2 (t.a)^2 (a the node's
// anisotropy, surface_anisotropy.rgb; transport::SurfaceCurvature): mu_up = mu + c_t (1 - mu^2),
// irradiance factor mu + c_t (1 - mu^2) - 2 c mu^2 (the area ratio is the mean curvature's).
// beam_upstream = 2 (transport::curved_particular): irradiance factor mu_up, and the particular
// solution below the curved surface: its narrowing H / sigma_t' in K (faded in over n.l 0..0.3)
// and its lateral terms (lateral_correction). A deformed node (H written 0) keeps the planar
// beam: its rest anisotropy is not read.
#include "optics.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

const uint MAX_LIGHTS = 8;
const uint MAX_VIEWS = 48;
const uint LIGHT_DIRECTIONAL = 0;
const uint LIGHT_POINT = 1;
const uint LIGHT_SPOT = 2;
const uint ENV_NONE = 0;
const uint ENV_CONSTANT = 1;
const uint ENV_SH = 2;
const float FP16_MAX = 65504.0;

struct GatherLight {
    vec4 position;  // xyz: position (point, spot) or direction of travel (directional); w: kind
    vec4 direction; // xyz: spot axis (unit); w: cos(outer)
    vec4 colour;    // rgb: irradiance (directional) or intensity; w: cos(inner)
    uvec4 views;    // x: first shadow view, y: view count (0: unshadowed, 1, or 6 cube faces)
};

struct ShadowView {
    mat4 view_proj;
    vec4 tile;  // xy: atlas texel origin, z: tile size in texels, w: world texel size (orthographic)
    vec4 eye;   // xyz: eye (perspective), w: world texel size per mm of distance (perspective)
};

layout(set = 0, binding = 0, rgba32f) uniform readonly image2D surface_position;
layout(set = 0, binding = 1, rgba16f) uniform readonly image2D surface_normal;
layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D q;
layout(set = 0, binding = 5, rgba16f) uniform writeonly image2D particular;
layout(set = 0, binding = 3) uniform sampler2D shadow_atlas;
// Heterogeneous levels: per node kappa and mu (rgb); a homogeneous material binds a stand-in.
layout(set = 0, binding = 6, rgba32f) uniform readonly image2D kappa;
layout(set = 0, binding = 7, rgba32f) uniform readonly image2D mu;
// rgb: the curvature's anisotropy per surface node (see the header); a level bound without one
// binds a stand-in that is read only with the upstream beam.
layout(set = 0, binding = 8, rgba16f) uniform readonly image2D surface_anisotropy;
layout(std430, set = 0, binding = 4) readonly buffer GatherScene {
    uvec4 counts;   // x: lights, y: environment kind
    vec4 sh[9];     // rgb: SH radiance coefficients, or sh[0].rgb the constant radiance
    GatherLight lights[MAX_LIGHTS];
    ShadowView views[MAX_VIEWS];
} scene;

layout(push_constant) uniform GatherPush {
    uvec2 extent;  // texture width, surface rows
    float q_scale;
    float eta;
    float normal_offset; // in shadow-map texels
    float env_transmittance; // 1 - F_dr,ext (flux-only query) or 1 - 2 C1(1/eta) (moments)
    float beam_local; // 1: the beam's coefficients per node from `kappa` and `mu`
    float beam_edge;  // 1: partly shadowed lights (PCF < 1) enter as the boundary flux
    vec4 beam_sigma_s; // rgb: sigma_s'; w: 1 = collimated source (DESIGN 2.7), 0 = boundary flux
                       // (`particular` zeroed), -1 = boundary flux, no `particular` of its own
    vec4 beam_sigma_a; // rgb: sigma_a; w: the boundary constant A
    vec4 beam_exit;    // x: (1 - 2 C1) / 4, y: (1 - 3 C2) / 2, z: the flux gain 4 / (1 - 2 C1),
                       // w: 1 = the second-collision source
    vec4 beam_kappa;   // rgb: D of a homogeneous material; w: 1 = Grosjean's D, 0 = 1 / (3 sigma_t')
    float beam_continuation; // 1: nodes facing away from a light get the beam through the wall
    float beam_upstream; // 1: the upstream beam (transport::upstream_beam), H in surface_normal.w;
                         // 2: with the curved particular solution (transport::curved_particular)
} pc;

// Quadrature points of second_collision_ratio's integral over mu (as the f64 reference).
const int SECOND_COLLISION_POINTS = 64;
// Smallest refracted cosine of the ratio (as transport::MIN_MU_T).
const float SECOND_COLLISION_MIN_MU_T = 1e-6;

// The quadrature's internal Fresnel reflectance r(1 / eta, m_i) at its points: it depends on
// eta alone, so each workgroup fills it once (main) and every node's integrals read it.
shared float second_collision_fresnel[SECOND_COLLISION_POINTS];

// The share of the once-scattered light of a beam (refracted cosine mu_t, per channel: the
// upstream beam's cosine differs by channel) that collides again, per channel:
// transport::second_collision_ratio, the same quadrature, at eta = pc.eta.
vec3 second_collision_ratio(vec3 sigma_s, vec3 sigma_a, vec3 d, vec3 mu_t) {
    vec3 b = 1.0 / max(mu_t, SECOND_COLLISION_MIN_MU_T);
    vec3 sigma_t = sigma_s + sigma_a;
    // s / sigma_t' with s = sqrt(sigma_a / D) (classical: sqrt(3 sigma_a sigma_t')).
    vec3 s = sqrt(sigma_a / d) / sigma_t;
    vec3 j = vec3(0.0);
    for (int i = 0; i < SECOND_COLLISION_POINTS; ++i) {
        float m = (float(i) + 0.5) / float(SECOND_COLLISION_POINTS);
        float r = second_collision_fresnel[i];
        j += 1.0 / ((s + b) * (1.0 + b * m)) + 1.0 / ((s + b) * (1.0 + s * m))
            + r * m / ((1.0 + s * m) * (1.0 + b * m));
    }
    j /= float(SECOND_COLLISION_POINTS);
    return sigma_s / sigma_t * (b + s) * 0.5 * j;
}

// transport::second_collision_fit: the effective refracted cosine mu_e = sigma_t' / beta' of the
// second-collision source fitted to the deep moment, 1/beta' = (r_T / r)(1/beta + z_b) - z_b,
// with r_T (transport::second_collision_deep_ratio, the same quadrature) and z_b = h = 2 A D.
const float DEEP_FIT_FULL_BELOW = 0.15;
const float DEEP_FIT_NONE_ABOVE = 0.3;
vec3 second_collision_depth(vec3 sigma_s, vec3 sigma_a, vec3 d, float a_const, vec3 mu_t,
                            vec3 r) {
    vec3 h = 2.0 * a_const * d;
    vec3 mt = max(mu_t, SECOND_COLLISION_MIN_MU_T);
    vec3 b = 1.0 / mt;
    vec3 sigma_t = sigma_s + sigma_a;
    vec3 zb = h * sigma_t;
    vec3 j = vec3(0.0);
    for (int i = 0; i < SECOND_COLLISION_POINTS; ++i) {
        float m = (float(i) + 0.5) / float(SECOND_COLLISION_POINTS);
        float rf = second_collision_fresnel[i];
        vec3 c = b * m / (b * m + 1.0);
        j += 2.0 * (mt + zb) - (zb - m) * c + rf * (zb + m) * c;
    }
    j /= float(SECOND_COLLISION_POINTS);
    vec3 r_t = sigma_s / sigma_t * 0.5 * j / (mt + zb);
    // transport::DEEP_FIT_FULL_BELOW / DEEP_FIT_NONE_ABOVE: the fit fades out with s / sigma_t'.
    vec3 s = sqrt(sigma_a / d) / sigma_t;
    vec3 weight = 1.0 - smoothstep(vec3(DEEP_FIT_FULL_BELOW), vec3(DEEP_FIT_NONE_ABOVE), s);
    vec3 mu_e = mt + weight * max((r_t / r) * (mt + zb) - zb - mt, vec3(0.0));
    return mix(mt, mu_e, greaterThan(r, vec3(0.0)));
}

// Relative distance kept from the resonance sigma_a mu_t^2 = sigma_t' / 3 (K infinite, phi_h
// cancelling it): coarser than the f64 reference's 1e-4, f32 keeps ~3 digits of the difference.
const float BEAM_RESONANCE_GUARD = 1e-3;
// transport::RESONANCE_FLUX_BELOW / RESONANCE_BEAM_ABOVE: the beam's share near the resonance.
const float RESONANCE_FLUX_BELOW = 0.25;
const float RESONANCE_BEAM_ABOVE = 0.5;

// Fraction of the 3x3 texels around p's projection whose depth is behind p: 1 = lit.
float visibility(uint index, vec3 p, vec3 n, float cos_l) {
    ShadowView v = scene.views[index];
    // Normal offset, in world texels at p, growing with the angle to the light: the PCF kernel
    // reaches a texel and a half from p's projection, where a tilted surface's own depth is
    // nearer the light by tan(theta) per texel (acne). Facing the light, no offset is needed.
    float texel = v.tile.w + v.eye.w * distance(p, v.eye.xyz);
    float sin_l = sqrt(max(1.0 - cos_l * cos_l, 0.0));
    vec4 clip = v.view_proj * vec4(p + n * (pc.normal_offset * texel * sin_l), 1.0);
    if (clip.w <= 0.0) {
        return 1.0;
    }
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) {
        return 1.0; // outside the view: the view covers the object, so nothing occludes here
    }
    float size = v.tile.z;
    ivec2 origin = ivec2(v.tile.xy);
    ivec2 centre = ivec2(floor((ndc.xy * 0.5 + 0.5) * size));
    float depth = clamp(ndc.z, 0.0, 1.0);
    float lit = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            // Clamped to the tile: a neighbouring tile belongs to another view.
            ivec2 t = clamp(centre + ivec2(dx, dy), ivec2(0), ivec2(size) - 1);
            float stored = texelFetch(shadow_atlas, origin + t, 0).r;
            lit += depth <= stored ? 1.0 : 0.0;
        }
    }
    return lit / 9.0;
}

// transport::UPSTREAM_SHIFT_LIMIT: the largest |c| of the upstream beam.
const float UPSTREAM_SHIFT_LIMIT = 0.2;

// The cube face (+X, -X, +Y, -Y, +Z, -Z) whose frustum holds direction d.
uint cube_face(vec3 d) {
    vec3 a = abs(d);
    if (a.x >= a.y && a.x >= a.z) {
        return d.x >= 0.0 ? 0u : 1u;
    }
    if (a.y >= a.z) {
        return d.y >= 0.0 ? 2u : 3u;
    }
    return d.z >= 0.0 ? 4u : 5u;
}

// Optical depth beyond which a beam through a wall is extinguished (sources::MAX_OPTICAL_DEPTH).
const float MAX_OPTICAL_DEPTH = 30.0;

// Distance from p towards the light (unit l) to the surface the shadow view `index` stores in
// front of p (its centre texel), or -1 where the view holds nothing in front of p. Along the ray
// the clip coordinates are linear in the distance t, so depth(t) = z(t) / w(t) = stored solves
// for t in closed form (orthographic and perspective views alike).
float entry_distance(uint index, vec3 p, vec3 l) {
    ShadowView v = scene.views[index];
    vec4 c = v.view_proj * vec4(p, 1.0);
    vec4 dc = v.view_proj * vec4(l, 0.0);
    if (c.w <= 0.0) {
        return -1.0;
    }
    vec3 ndc = c.xyz / c.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) {
        return -1.0;
    }
    float size = v.tile.z;
    ivec2 t = clamp(ivec2(floor((ndc.xy * 0.5 + 0.5) * size)), ivec2(0), ivec2(size) - 1);
    float stored = texelFetch(shadow_atlas, ivec2(v.tile.xy) + t, 0).r;
    float denom = dc.z - stored * dc.w;
    if (stored >= clamp(ndc.z, 0.0, 1.0) || abs(denom) < 1e-20) {
        return -1.0;
    }
    return max((stored * c.w - c.z) / denom, 0.0);
}

// The particular solution of a beam transmitting `transmitted` (E mu_i T_i per channel, refracted
// cosine mu_t per channel) into the medium of the node: (K, beta K) with the second-collision fit when on,
// and the part entering as the boundary flux (`resonance`: near the particular solution's
// resonance, transport::beam_share; otherwise none, as the f64 continuation). DESIGN 2.7.
// `curved`: the mean curvature in transport mean free paths, H / sigma_t' per channel (0: planar):
// K = Q0 / (sigma_a - D beta^2 (1 + 2 curved mu_p)), transport::beam_particular_curved.
void beam_particular(vec3 transmitted, vec3 mu_t, bool resonance, vec3 beam_s, vec3 beam_a,
                     vec3 beam_d, vec3 curved, out vec3 k, out vec3 beta_k, out vec3 flux) {
    vec3 sigma_a = beam_a;
    vec3 sigma_t = beam_s + sigma_a;
    // The second-collision source scales the whole source, its flux fallback included
    // (the once-scattered light is the march's, added whole).
    vec3 gain = pc.beam_exit.w > 0.5
        ? second_collision_ratio(beam_s, sigma_a, beam_d, mu_t)
        : vec3(1.0);
    // The particular solution's cosine: mu_t, or the second collision's fitted mu_e.
    vec3 mu_p = pc.beam_exit.w > 0.5
        ? second_collision_depth(beam_s, sigma_a, beam_d, pc.beam_sigma_a.w, mu_t, gain)
        : mu_t;
    vec3 a = sigma_a * (mu_p * mu_p);
    // D sigma_t'^2 (sigma_t' / 3 with the classical D).
    vec3 b = beam_d * sigma_t * sigma_t;
    // Near the resonance the solve cannot cancel a large K: that share of the light
    // enters as the boundary flux (transport::beam_share, the same smoothstep).
    vec3 share = resonance
        ? smoothstep(vec3(RESONANCE_FLUX_BELOW), vec3(RESONANCE_BEAM_ABOVE), abs(a - b) / (a + b))
        : vec3(1.0);
    flux = transmitted * (1.0 - share) * gain;
    // Under a curved surface the depth's Laplacian adds D 2 H beta (the share stays planar).
    vec3 b_curved = b * (1.0 + 2.0 * curved * mu_p);
    vec3 denom = a - b_curved;
    vec3 guard = BEAM_RESONANCE_GUARD * (a + b_curved);
    denom = mix(denom, -guard, lessThan(abs(denom), guard));
    // The fitted source keeps the half-space reflectance's moment: gain r (1 + s~ mu_e) /
    // (1 + s~ mu_t) with Q0 over mu_e (transport::second_collision_fit), s~ = s / sigma_t'.
    vec3 s_mfp = sqrt(sigma_a / beam_d) / sigma_t;
    vec3 beam_gain = gain * (1.0 + s_mfp * mu_p)
        / (1.0 + s_mfp * max(mu_t, SECOND_COLLISION_MIN_MU_T));
    beam_gain = pc.beam_exit.w > 0.5 ? beam_gain : vec3(1.0);
    vec3 source = beam_s * transmitted * share * beam_gain;
    k = source * mu_p / denom;
    beta_k = source * sigma_t / denom;
}

const float NARROWING_FULL_ABOVE = 0.3;

// The upstream beam's particular solution for a node cosine `mu` (transport::upstream_beam, then
// transport::beam_particular_curved), everything else held: c_t the turn's and c the particular
// solution's curvature per channel, e_vis = E times the visibility.
// `c_area` = H / (eta sigma_t'): wave 8's area factor; `curved` the curved particular solution's
// share (0 with beam_upstream 1; transport::SurfaceCurvature::umbilic_share with 2).
void upstream_particular(float mu, vec3 c_t, vec3 c, vec3 c_area, float curved, vec3 e_vis,
                         vec3 beam_s, vec3 beam_a, vec3 beam_d, out vec3 k, out vec3 beta_k,
                         out vec3 flux) {
    // Each channel's beam has its own upstream cosine: channel c of every vec3 below is channel
    // c's beam (one evaluation for the three, the same values as three).
    vec3 mu_up = min(mu + c_t * (1.0 - mu * mu), vec3(1.0));
    vec3 area = max(mu + c_t * (1.0 - mu * mu) - 2.0 * c_area * mu * mu, vec3(0.0));
    vec3 factor = mix(vec3(0.0), mix(area, mu_up, curved), greaterThan(mu_up, vec3(0.0)));
    vec3 mt = sqrt(max(1.0 - (1.0 - mu_up * mu_up) / (pc.eta * pc.eta), vec3(0.0)));
    vec3 ft = vec3(fresnel_transmittance(pc.eta, max(mu_up.r, 0.0)),
                   fresnel_transmittance(pc.eta, max(mu_up.g, 0.0)),
                   fresnel_transmittance(pc.eta, max(mu_up.b, 0.0)));
    // transport::NARROWING_FULL_ABOVE: the narrowing fades to none at the terminator.
    vec3 narrowing = curved * c * smoothstep(0.0, NARROWING_FULL_ABOVE, mu);
    beam_particular(e_vis * factor * ft, mt, true, beam_s, beam_a, beam_d, narrowing, k, beta_k,
                    flux);
}

// transport::SurfaceCurvature::umbilic_share, UMBILIC_SHARE_POWER = 4, from 1 - |k1 - k2| /
// (|k1| + |k2|).
float umbilic_share(float isotropy) {
    float s = clamp(isotropy, 0.0, 1.0);
    s *= s;
    return s * s;
}

// transport::LATERAL_STEP, LATERAL_FULL_ABOVE.
const float LATERAL_STEP = 0.02;
const float LATERAL_FULL_ABOVE = 0.5;
const float LATERAL_GUARD_FROM = 0.15;

// transport::lateral_correction: the particular solution's lateral terms folded into K (dK per
// channel), from central differences in the node cosine about min(mu, 1 - step); g =
// H^2 + |a|^4 and g_along = |S t|^2 along the beam's tangent (1/mm^2), c = H / sigma_t' per
// channel; 0 where any of the three is unlit.
vec3 lateral_correction(float mu, vec3 c_t, vec3 c, vec3 c_area, float g, float g_along,
                        float share, vec3 e_vis, vec3 beam_s, vec3 beam_a, vec3 beam_d) {
    vec3 sigma_t = beam_s + beam_a;
    float fade = smoothstep(0.0, LATERAL_FULL_ABOVE, mu);
    vec3 gc = min(vec3(g), (UPSTREAM_SHIFT_LIMIT * sigma_t) * (UPSTREAM_SHIFT_LIMIT * sigma_t));
    if (fade == 0.0 || !(g > 0.0)) {
        return vec3(0.0);
    }
    // transport::LATERAL_GUARD_FROM: none where the unclamped c = sqrt(g) / sigma_t' nears the clamp.
    vec3 guard = vec3(1.0) - smoothstep(vec3(LATERAL_GUARD_FROM), vec3(UPSTREAM_SHIFT_LIMIT),
                                        vec3(sqrt(g)) / sigma_t);
    float m = min(mu, 1.0 - LATERAL_STEP);
    vec3 k0, bk0, kp, bkp, km, bkm, unused;
    upstream_particular(m, c_t, c, c_area, share, e_vis, beam_s, beam_a, beam_d, k0, bk0, unused);
    upstream_particular(m + LATERAL_STEP, c_t, c, c_area, share, e_vis, beam_s, beam_a, beam_d,
                        kp, bkp, unused);
    upstream_particular(m - LATERAL_STEP, c_t, c, c_area, share, e_vis, beam_s, beam_a, beam_d,
                        km, bkm, unused);
    bvec3 lit = bvec3(vec3(notEqual(k0, vec3(0.0))) * vec3(notEqual(kp, vec3(0.0)))
                      * vec3(notEqual(km, vec3(0.0))));
    vec3 safe_k0 = mix(vec3(1.0), k0, lit);
    vec3 b0 = bk0 / safe_k0;
    vec3 bp = bkp / mix(vec3(1.0), kp, lit);
    vec3 bm = bkm / mix(vec3(1.0), km, lit);
    float step = LATERAL_STEP;
    vec3 dk = (kp - km) / (2.0 * step);
    vec3 d2k = (kp - 2.0 * k0 + km) / (step * step);
    vec3 db = (bp - bm) / (2.0 * step);
    vec3 d2b = (bp - 2.0 * b0 + bm) / (step * step);
    // |grad mu|^2 / g over (1 - mu^2): the beam's direction's share of the curvature.
    float w = clamp(g_along / g, 0.0, 2.0) * (1.0 - m * m);
    vec3 lk = w * d2k - 2.0 * m * dk;
    vec3 lb = w * d2b - 2.0 * m * db;
    vec3 lat = lk / b0 - (2.0 * w * dk * db + k0 * lb) / (b0 * b0)
        + 2.0 * k0 * db * db * w / (b0 * b0 * b0);
    vec3 narrowing = share * c * smoothstep(0.0, NARROWING_FULL_ABOVE, mu);
    vec3 denom = beam_a - beam_d * b0 * b0 * (1.0 + 2.0 * narrowing * sigma_t / b0);
    vec3 d_k = share * fade * guard * beam_d * gc * lat * b0 / denom;
    bvec3 bad = bvec3(vec3(isnan(d_k)) + vec3(isinf(d_k)));
    return mix(mix(vec3(0.0), d_k, lit), vec3(0.0), bad);
}

void main() {
    // Before any invocation returns: barrier() needs the whole workgroup.
    for (uint i = gl_LocalInvocationIndex; i < uint(SECOND_COLLISION_POINTS);
         i += gl_WorkGroupSize.x * gl_WorkGroupSize.y) {
        float m = (float(i) + 0.5) / float(SECOND_COLLISION_POINTS);
        second_collision_fresnel[i] = fresnel_reflectance(1.0 / pc.eta, m);
    }
    barrier();
    ivec2 texel = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(uvec2(texel), pc.extent))) {
        return;
    }
    vec4 position = imageLoad(surface_position, texel);
    if (position.a != 1.0) {
        return; // padding texel: q is only defined at surface nodes
    }
    vec3 p = position.xyz;
    vec4 normal_curvature = imageLoad(surface_normal, texel);
    vec3 n = normal_curvature.xyz;
    float curvature = normal_curvature.w;
    // fp16 normals are unit only to ~5e-4; renormalize so n.l matches the f64 reference.
    n = length(n) > 0.0 ? normalize(n) : vec3(0.0);

    vec3 sum = vec3(0.0);
    vec3 part = vec3(0.0);
    // The light's visibility behind `part` where it is the lit beam's (`part` then proportional
    // to it), written into the particular image's alpha; -1 where `part` is not (no lit beam, a
    // wall's continuation, past the terminator, more than one light): the interior pass's own
    // visibility (vertex_interior.glsl) scales only the first kind.
    float own = -1.0;
    bool beams = pc.beam_sigma_s.w > 0.5;
    vec3 beam_s = pc.beam_sigma_s.rgb;
    vec3 beam_a = pc.beam_sigma_a.rgb;
    vec3 beam_d = pc.beam_kappa.rgb;
    if (beams && pc.beam_local > 0.5) {
        vec3 k = imageLoad(kappa, texel).rgb;
        vec3 m = imageLoad(mu, texel).rgb;
        beam_a = m;
        beam_d = k;
        // sigma_t' from D and sigma_a (material::DiffusionCoefficient::sigma_t).
        vec3 sigma_t = pc.beam_kappa.w > 0.5
            ? (1.0 + sqrt(1.0 + 12.0 * k * m)) / (6.0 * k)
            : 1.0 / (3.0 * k);
        beam_s = max(sigma_t - m, vec3(0.0));
    }
    for (uint i = 0; i < min(scene.counts.x, MAX_LIGHTS); ++i) {
        GatherLight light = scene.lights[i];
        uint kind = uint(light.position.w);
        vec3 l;
        vec3 e;
        if (kind == LIGHT_DIRECTIONAL) {
            l = -light.position.xyz;
            e = light.colour.rgb;
        } else {
            vec3 to_light = light.position.xyz - p;
            // As the f64 reference: a light sitting on a node must not divide by zero.
            float r = max(length(to_light), 1e-9);
            l = to_light / r;
            float falloff = 1.0;
            if (kind == LIGHT_SPOT) {
                float cos_axis = dot(-l, light.direction.xyz);
                float co = light.direction.w;
                float ci = light.colour.w;
                if (ci - co > 1e-12) {
                    float t = clamp((cos_axis - co) / (ci - co), 0.0, 1.0);
                    falloff = t * t * (3.0 - 2.0 * t);
                } else {
                    falloff = cos_axis >= co ? 1.0 : 0.0;
                }
            }
            // Divided in two steps: r^2 underflows or overflows fp32 long before E does.
            e = light.colour.rgb * falloff / r / r;
        }
        float cos_l = dot(n, l);
        if (all(equal(e, vec3(0.0)))) {
            continue;
        }
        // h = 2 A D: the Robin row's extrapolation length.
        vec3 h = 2.0 * pc.beam_sigma_a.w * beam_d;
        if (beams && pc.beam_upstream > 0.5 && cos_l > -UPSTREAM_SHIFT_LIMIT) {
            // transport::upstream_beam per channel.
            vec3 sigma_t = beam_s + beam_a;
            float mu = clamp(cos_l, -1.0, 1.0);
            // transport::SurfaceCurvature::along: the normal curvature along the beam's tangent.
            vec3 beam_tangent = l - n * mu;
            float along_curvature = curvature;
            vec3 a = curvature != 0.0 ? imageLoad(surface_anisotropy, texel).rgb : vec3(0.0);
            // transport::SurfaceCurvature::squared: H^2 + |a|^4.
            float curvature_squared = curvature * curvature + dot(a, a) * dot(a, a);
            if (curvature != 0.0 && length(beam_tangent) > 1e-6) {
                float ta = dot(normalize(beam_tangent), a);
                along_curvature = curvature - dot(a, a) + 2.0 * ta * ta;
            }
            // transport::SurfaceCurvature::squared_along: g + 2 H (k_t - H) (g at the pole).
            float curvature_squared_along =
                max(curvature_squared + 2.0 * curvature * (along_curvature - curvature), 0.0);
            vec3 inv_eta_sigma = 1.0 / (pc.eta * max(sigma_t, vec3(1e-12)));
            vec3 c_t = clamp(along_curvature * inv_eta_sigma,
                             vec3(-UPSTREAM_SHIFT_LIMIT), vec3(UPSTREAM_SHIFT_LIMIT));
            // The particular solution's curvature, H / sigma_t' (geometric: no eta).
            vec3 c = clamp(curvature / max(sigma_t, vec3(1e-12)),
                           vec3(-UPSTREAM_SHIFT_LIMIT), vec3(UPSTREAM_SHIFT_LIMIT));
            vec3 c_area = clamp(curvature * inv_eta_sigma,
                                vec3(-UPSTREAM_SHIFT_LIMIT), vec3(UPSTREAM_SHIFT_LIMIT));
            // transport::SurfaceCurvature::umbilic_share: the curved particular solution's share.
            float a2 = dot(a, a);
            float k_sum = abs(curvature + a2) + abs(curvature - a2);
            float curved = pc.beam_upstream > 1.5
                ? (k_sum > 0.0 ? umbilic_share(1.0 - 2.0 * a2 / k_sum) : 1.0)
                : 0.0;
            vec3 mu_up = min(mu + c_t * (1.0 - mu * mu), vec3(1.0));
            vec3 area = max(mu + c_t * (1.0 - mu * mu) - 2.0 * c_area * mu * mu, vec3(0.0));
            vec3 factor = mix(vec3(0.0), mix(area, mu_up, curved), greaterThan(mu_up, vec3(0.0)));
            float vis = 1.0;
            if (light.views.y != 0u) {
                uint view = light.views.y == 6u ? light.views.x + cube_face(-l) : light.views.x;
                if (cos_l > 0.0) {
                    vis = visibility(view, p, n, cos_l);
                } else {
                    // Past the terminator: a mean free path upstream (sources.rs `upstream`).
                    vec3 along = l - n * mu;
                    vec3 t = length(along) > 1e-6 ? normalize(along) : vec3(0.0);
                    float mfp = 3.0 / max(sigma_t.r + sigma_t.g + sigma_t.b, 1e-12);
                    vec3 n_up = normalize(n + t * (along_curvature * mfp));
                    vis = visibility(view, p + t * mfp, n_up, max(dot(n_up, l), 0.0));
                }
            }
            // As the f64 reference: unlit upstream, or nothing reaching the node, keeps the
            // usual arrival below.
            if (vis > 0.0 && any(greaterThan(factor, vec3(0.0)))) {
                if (pc.beam_edge > 0.5 && vis < 1.0) {
                    vec3 mi = mu_up;
                    vec3 mt = sqrt(max(1.0 - (1.0 - mi * mi) / (pc.eta * pc.eta), vec3(0.0)));
                    vec3 ft = vec3(fresnel_transmittance(pc.eta, max(mi.r, 0.0)),
                                   fresnel_transmittance(pc.eta, max(mi.g, 0.0)),
                                   fresnel_transmittance(pc.eta, max(mi.b, 0.0)));
                    vec3 tr = e * (factor * ft * vis);
                    vec3 gain = pc.beam_exit.w > 0.5
                        ? second_collision_ratio(beam_s, beam_a, beam_d, mt)
                        : vec3(1.0);
                    sum += tr * gain;
                } else {
                    vec3 k, beta_k, flux;
                    upstream_particular(mu, c_t, c, c_area, curved, e * vis, beam_s, beam_a,
                                        beam_d, k, beta_k, flux);
                    // The lateral terms: K gains dK, beta unchanged (beta K scales with it).
                    vec3 d_k = curved > 0.0
                        ? lateral_correction(mu, c_t, c, c_area, curvature_squared,
                                             curvature_squared_along, curved, e * vis, beam_s,
                                             beam_a, beam_d)
                        : vec3(0.0);
                    vec3 beta = beta_k / mix(k, vec3(1.0), equal(k, vec3(0.0)));
                    k += d_k;
                    beta_k = beta * k;
                    sum += flux - (k + h * beta_k) / pc.beam_exit.z;
                    part += pc.beam_exit.x * k - pc.beam_exit.y * beam_d * beta_k;
                    if (cos_l > 0.0) {
                        own = vis;
                    }
                }
                continue;
            }
        }
        if (cos_l <= 0.0) {
            // Facing away: the beam that entered on the light's side of the wall, if any.
            if (!beams || pc.beam_continuation < 0.5 || light.views.y == 0u) {
                continue;
            }
            uint view = light.views.y == 6u ? light.views.x + cube_face(-l) : light.views.x;
            float t = entry_distance(view, p, l);
            if (t <= 0.0) {
                continue;
            }
            // The entry face parallel to this one (a wall): incidence mu_i = -n.l there.
            float mu_i = -cos_l;
            float mu_t = sqrt(max(1.0 - (1.0 - mu_i * mu_i) / (pc.eta * pc.eta), 0.0));
            vec3 e_in = e;
            if (kind != LIGHT_DIRECTIONAL) {
                // The inverse square at the entry, t nearer the light on the same ray.
                float r = max(length(light.position.xyz - p), 1e-9);
                float ratio = r / max(r - t, 1e-9);
                e_in = e * ratio * ratio;
            }
            // Jensen's refraction correction: the refracted path to the same depth below the
            // entry face is t mu_i / mu_t (sources.rs `Arrival::Behind`).
            vec3 tau = (beam_s + beam_a) * (t * mu_i / max(mu_t, SECOND_COLLISION_MIN_MU_T));
            vec3 attenuation = mix(exp(-tau), vec3(0.0), greaterThan(tau, vec3(MAX_OPTICAL_DEPTH)));
            vec3 transmitted = e_in * (mu_i * fresnel_transmittance(pc.eta, mu_i));
            vec3 k, beta_k, flux;
            beam_particular(transmitted, vec3(mu_t), false, beam_s, beam_a, beam_d, vec3(0.0), k,
                            beta_k, flux);
            k *= attenuation;
            beta_k *= attenuation;
            // Grazing (h beta > 1, mu_t below about 2/3 at eta 1) the right-hand side turns
            // negative, which q (clamped at zero) cannot carry while the exit part would still be
            // added: those channels take nothing (the f64 reference keeps them; with the faces
            // parallel such a node is mostly a face at an angle to the entry, where the parallel
            // entry is wrong anyway).
            bvec3 carried = greaterThanEqual(h * beta_k - k, vec3(0.0));
            k = mix(vec3(0.0), k, carried);
            beta_k = mix(vec3(0.0), beta_k, carried);
            // phi_p = K e^{-beta z}, its derivative along this face's inward normal (the
            // entry's outward one, n . n_entry = -1) +beta K: Robin -(phi_p - h dphi_p/dz_in).
            sum += -(k - h * beta_k) / pc.beam_exit.z;
            part += pc.beam_exit.x * k + pc.beam_exit.y * beam_d * beta_k;
            continue;
        }
        float vis = 1.0;
        if (light.views.y == 1u) {
            vis = visibility(light.views.x, p, n, cos_l);
        } else if (light.views.y == 6u) {
            vis = visibility(light.views.x + cube_face(-l), p, n, cos_l);
        }
        vec3 transmitted = e * (cos_l * fresnel_transmittance(pc.eta, cos_l) * vis);
        if (!beams) {
            // Paper Eq. 3 for a delta light: E (n . w_i) F_t(w_i), shadowed.
            sum += transmitted;
            continue;
        }
        // DESIGN 2.7 with Q0 = sigma_s' q_l / mu_t (q_l = E mu_i T_i, shadowed); written
        // as K = sigma_s' q_l mu_t / (sigma_a mu_t^2 - sigma_t' / 3) and beta K =
        // sigma_s' q_l sigma_t' / (same), finite as mu_t -> 0 (grazing beams at eta = 1).
        float mu_t = sqrt(max(1.0 - (1.0 - cos_l * cos_l) / (pc.eta * pc.eta), 0.0));
        if (pc.beam_edge > 0.5 && vis < 1.0) {
            // A shadow edge: the flat half-space fails; the boundary flux (scaled as the
            // second-collision source's flux part).
            vec3 gain = pc.beam_exit.w > 0.5
                ? second_collision_ratio(beam_s, beam_a, beam_d, vec3(mu_t))
                : vec3(1.0);
            sum += transmitted * gain;
            continue;
        }
        vec3 k, beta_k, flux;
        beam_particular(transmitted, vec3(mu_t), true, beam_s, beam_a, beam_d, vec3(0.0), k,
                        beta_k, flux);
        sum += flux;
        // Robin right-hand side -K (1 + h beta), h = 2 A D, as an equivalent flux.
        sum += -(k + h * beta_k) / pc.beam_exit.z;
        part += pc.beam_exit.x * k - pc.beam_exit.y * beam_d * beta_k;
        own = vis;
    }
    if (scene.counts.x != 1u) {
        own = -1.0;
    }

    uint env = scene.counts.y;
    if (env != ENV_NONE) {
        vec3 e_env;
        if (env == ENV_CONSTANT) {
            e_env = PI * scene.sh[0].rgb;
        } else {
            vec3 c[9];
            for (int k = 0; k < 9; ++k) {
                c[k] = scene.sh[k].rgb;
            }
            e_env = sh_irradiance(c, n);
        }
        // Paper Eq. 3 over the sphere of directions with F_t averaged: E_env (1 - F_dr,ext).
        sum += e_env * pc.env_transmittance;
    }

    vec3 scaled = sum * pc.q_scale;
    // Never NaN or Inf into the solver: fp16 saturates rather than overflowing to Inf.
    scaled = clamp(mix(scaled, vec3(0.0), isnan(scaled)), vec3(0.0), vec3(FP16_MAX));
    imageStore(q, texel, vec4(scaled, 1.0));
    if (pc.beam_sigma_s.w >= 0.0) {
        vec3 p_scaled = part * pc.q_scale;
        p_scaled = clamp(mix(p_scaled, vec3(0.0), isnan(p_scaled)), vec3(-FP16_MAX), vec3(FP16_MAX));
        imageStore(particular, texel, vec4(p_scaled, own));
    }
}
