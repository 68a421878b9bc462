#version 460
// Single scattering (DESIGN 2.8), per display vertex, for the frame's eye: the mirror of the f64
// `solver::single_scattering::vertex_single_scattering`. The view ray is refracted at the vertex
// (w_o', cosine mu_o' inside) and sampled at `samples` depths t_k stratified in the exponential of
// sigma_t' truncated at the far face: the exit distance t_max along the refracted ray is where the
// ray first passes behind the nearest back face the eye sees (the pass's own back-face depth
// view, tile 0 of `depths`; exact at eta = 1, where the refracted ray is the eye's). At each x_k
// every light's beam enters where the light's view sees the object first (an unbiased depth
// view of the same projection as the shadow view, tile 1 + view of `depths`; the entry's normal
// n_i from the depth's gradient), refracts (T_i, mu_t), travels to x_k with Jensen's correction
// s mu_i / mu_t, is scattered with p = 1 / (4 pi) (reduced coefficients) and leaves with
// T_o / eta^2 (the shading multiplies by F_t / (pi eta^2), so X = pi S is written, S the sum of
// 2.8):
//   S = sum_k w_k sigma_s' p (E T_i mu_i / mu_t) exp(-tau_L - tau_V).
// A sample the light's view sees more than a texel in front of the first surface is outside the
// object (on the light's side): it contributes nothing. Difference mode (`mode` 1) subtracts the
// flat-surface closed form alpha p E mu_i T_i / (mu_t + mu_o') of each light that lights the
// vertex directly (visibility by 3x3 PCF of the biased shadow atlas, as the gather), which the
// diffusion source carries. Whole mode (`mode` 2) adds the environment's flat closed form
// (`mode` 3: that alone, no light above the error budget). Heterogeneous materials (the `medium`
// grid): sigma_s' at x_k, tau_V and tau_L by DEPTH_SAMPLES midpoints through the field.
#include "optics.glsl"

layout(local_size_x = 64) in;

const uint MAX_LIGHTS = 8;
const uint MAX_VIEWS = 48;
const uint LIGHT_DIRECTIONAL = 0;
const uint LIGHT_SPOT = 2;
const uint VERTEX_FLOATS = 9; // mesh::Vertex: position, normal, exitance
// Beyond this optical depth a path contributes nothing worth its exp (exp(-30)), as the f64 path.
const float MAX_OPTICAL_DEPTH = 30.0;
// Smallest inside cosine of a refracted beam (grazing at eta = 1): keeps E mu_i / mu_t finite.
const float MIN_MU_T = 1e-4;

struct GatherLight {
    vec4 position;
    vec4 direction;
    vec4 colour;
    uvec4 views;
};

struct ShadowView {
    mat4 view_proj;
    vec4 tile;
    vec4 eye;
};

layout(std430, set = 0, binding = 0) readonly buffer Vertices {
    float data[];
} vertices;
layout(std430, set = 0, binding = 1) writeonly buffer Scattered {
    vec4 x[];
} scattered;
layout(set = 0, binding = 2) uniform sampler2D shadow_atlas;
layout(std430, set = 0, binding = 3) readonly buffer GatherScene {
    uvec4 counts;
    vec4 sh[9];
    GatherLight lights[MAX_LIGHTS];
    ShadowView views[MAX_VIEWS];
} scene;
// Unbiased depths: tile 0 the eye's back faces, tile 1 + i the front of shadow view i.
layout(set = 0, binding = 4) uniform sampler2D depths;
// The eye's back-face view: its projection, tile (xy origin, z size; z = 0: none, the march is
// not truncated) and the object's bounding sphere (xyz centre, w radius, mm).
// Also, per shadow view, the inverse of its projection (the entry lookups' unprojection, once a
// frame on the host rather than per depth and light here).
layout(std430, set = 0, binding = 5) readonly buffer ExitView {
    mat4 view_proj;
    vec4 tile;
    vec4 bounds;
    mat4 entry_inverses[MAX_VIEWS];
} exit_view;

// The material (frame::single_scattering::MediumHeader): a heterogeneous field on a grid of
// nodes (trilinear), or (nodes.y = 0) the push constants' coefficients everywhere.
layout(std430, set = 0, binding = 6) readonly buffer Medium {
    uvec4 nodes;   // x: nodes per axis; y: 1 = heterogeneous
    vec4 origin;   // xyz: the first node (mm)
    vec4 spacing;  // xyz: node spacing (mm)
    vec4 values[]; // per node: sigma_s' (rgb), then sigma_a (rgb); x fastest
} medium;

layout(push_constant) uniform ScatterPush {
    vec4 eye;       // xyz: the camera's eye (object frame, mm)
    vec4 sigma_s;   // rgb: sigma_s' (1/mm); w: eta
    vec4 sigma_a;   // rgb: sigma_a (1/mm); w: offset (mm) of the march's start below the vertex
    uint vertex_count;
    uint samples;
    uint mode;      // 0: zeros (the march is skipped); 1: difference to the flat closed form;
                    // 2: whole, with the environment's; 3: the environment's alone (no light)
    float normal_offset; // shadow-map texels, for the vertex's own visibility
    uint columns;   // tiles per row of `depths`
} pc;

// Material samples per segment for heterogeneous optical depths, midpoint rule (as the f64
// reference's DEPTH_SAMPLES).
const int DEPTH_SAMPLES = 8;

bool heterogeneous() {
    return medium.nodes.y == 1u && medium.nodes.x >= 2u;
}

// sigma_s' and sigma_a at p: the grid's trilinear interpolation (clamped to its box, as a
// `.vol` repeats its border), or the push constants' for a homogeneous material.
void coefficients_at(vec3 p, out vec3 s, out vec3 a) {
    s = pc.sigma_s.rgb;
    a = pc.sigma_a.rgb;
    if (!heterogeneous()) {
        return;
    }
    int n = int(medium.nodes.x);
    vec3 g = clamp((p - medium.origin.xyz) / medium.spacing.xyz, vec3(0.0), vec3(float(n - 1)));
    ivec3 i = min(ivec3(floor(g)), ivec3(n - 2));
    vec3 f = g - vec3(i);
    s = vec3(0.0);
    a = vec3(0.0);
    for (int c = 0; c < 8; ++c) {
        ivec3 d = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
        vec3 w3 = mix(1.0 - f, f, vec3(d));
        float w = w3.x * w3.y * w3.z;
        ivec3 q = i + d;
        int node = (q.z * n + q.y) * n + q.x;
        s += w * medium.values[2 * node].rgb;
        a += w * medium.values[2 * node + 1].rgb;
    }
}

// Optical depth per channel along the segment from a to b (solver::single_scattering's
// optical_depth: exact for a homogeneous material, DEPTH_SAMPLES midpoints through the field).
vec3 optical_depth(vec3 a, vec3 b) {
    float len = distance(a, b);
    if (!heterogeneous()) {
        return (pc.sigma_s.rgb + pc.sigma_a.rgb) * len;
    }
    vec3 tau = vec3(0.0);
    for (int k = 0; k < DEPTH_SAMPLES; ++k) {
        vec3 s;
        vec3 m;
        coefficients_at(mix(a, b, (float(k) + 0.5) / float(DEPTH_SAMPLES)), s, m);
        tau += (s + m) * (len / float(DEPTH_SAMPLES));
    }
    return tau;
}

// transport::diffuse_quadrature: 8-point Gauss-Legendre on [-1, 1] in u = mu_i^2 (cosine
// weighted, weights summing to 1), the environment's incident cosines.
const float GAUSS_X[4] = float[](0.1834346424956498, 0.5255324099163290, 0.7966664774136267,
                                 0.9602898564975363);
const float GAUSS_W[4] = float[](0.3626837833783620, 0.3137066458778873, 0.2223810344533745,
                                 0.1012285362903763);
const uint ENV_NONE = 0;
const uint ENV_CONSTANT = 1;
// Azimuths per incident cosine of an SH environment (sources::ENV_AZIMUTHS).
const int ENV_AZIMUTHS = 8;

// The environment's radiance towards -d (sources::environment_radiance: SH order 2, clamped).
vec3 environment_radiance(vec3 d) {
    if (scene.counts.y == ENV_CONSTANT) {
        return scene.sh[0].rgb;
    }
    vec3 v = scene.sh[0].rgb * 0.282095
        + 0.488603 * (scene.sh[1].rgb * d.y + scene.sh[2].rgb * d.z + scene.sh[3].rgb * d.x)
        + 1.092548 * (scene.sh[4].rgb * d.x * d.y + scene.sh[5].rgb * d.y * d.z
                      + scene.sh[7].rgb * d.x * d.z)
        + 0.315392 * scene.sh[6].rgb * (3.0 * d.z * d.z - 1.0)
        + 0.546274 * scene.sh[8].rgb * (d.x * d.x - d.y * d.y);
    return max(v, vec3(0.0));
}

// The environment's single scattering by DESIGN 2.8's flat closed form (unshadowed, as its
// diffusion part), summed over the environment as beams (sources::environment_beams): per
// quadrature cosine mu_i the irradiance pi w L (L averaged over the azimuth), times
// albedo p T_i / (mu_t + mu_o'). The whole mode's environment term, as the f64 reference's.
vec3 environment_single_scattering(vec3 n, vec3 albedo, float mu_o_inside, float eta) {
    if (scene.counts.y == ENV_NONE) {
        return vec3(0.0);
    }
    vec3 helper = abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0);
    vec3 t = normalize(cross(helper, n));
    vec3 b = cross(n, t);
    vec3 sum = vec3(0.0);
    for (int k = 0; k < 4; ++k) {
        for (int side = 0; side < 2; ++side) {
            float mu = sqrt(0.5 * (1.0 + (side == 0 ? -GAUSS_X[k] : GAUSS_X[k])));
            float weight = 0.5 * GAUSS_W[k];
            vec3 radiance = vec3(0.0);
            if (scene.counts.y == ENV_CONSTANT) {
                radiance = scene.sh[0].rgb;
            } else {
                float sin_i = sqrt(max(1.0 - mu * mu, 0.0));
                for (int a = 0; a < ENV_AZIMUTHS; ++a) {
                    float phi = 2.0 * PI * (float(a) + 0.5) / float(ENV_AZIMUTHS);
                    vec3 d = n * mu + (t * cos(phi) + b * sin(phi)) * sin_i;
                    radiance += environment_radiance(d) / float(ENV_AZIMUTHS);
                }
            }
            vec3 irr = PI * weight * radiance;
            float mu_t = sqrt(max(1.0 - (1.0 - mu * mu) / (eta * eta), 0.0));
            sum += albedo / (4.0 * PI) * irr * fresnel_transmittance(eta, mu)
                / max(mu_t + mu_o_inside, MIN_MU_T);
        }
    }
    return sum;
}

// Steps of the search for the far face (quadratically spaced: fine near the start, where
// silhouette chords are short) and bisections of the step that leaves.
const int EXIT_STEPS = 24;
const int EXIT_BISECTIONS = 10;
// Below this cosine the tangent plane's crossing is ill-conditioned: the distance along the
// light to the stored point is used instead.
const float MIN_PLANE_COSINE = 0.05;

// The cube face (+X, -X, +Y, -Y, +Z, -Z) whose frustum holds direction d (as gather_q.comp).
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

vec3 vertex_vec3(uint v, uint offset) {
    uint b = v * VERTEX_FLOATS + offset;
    return vec3(vertices.data[b], vertices.data[b + 1], vertices.data[b + 2]);
}

// The world point of texel t of view `v` at its stored depth; w = 0 where nothing was drawn.
vec4 stored_point(ShadowView v, ivec2 origin, mat4 inv, ivec2 t) {
    ivec2 size = ivec2(v.tile.z);
    t = clamp(t, ivec2(0), size - 1);
    float depth = texelFetch(depths, origin + t, 0).r;
    if (depth >= 1.0) {
        return vec4(0.0);
    }
    vec2 ndc = (vec2(t) + 0.5) / v.tile.z * 2.0 - 1.0;
    vec4 p = inv * vec4(ndc, depth, 1.0);
    return vec4(p.xyz / p.w, 1.0);
}

// The top-left texel of tile `tile` of `depths` (tiles of `size` texels, `pc.columns` a row).
ivec2 tile_origin(uint tile, float size) {
    return ivec2(int(tile % pc.columns), int(tile / pc.columns)) * int(size);
}

// Where the light's beam towards x enters the object, as stored unbiased (xyz; w: the view's
// texel size in mm there; w = 0: nothing drawn there, or outside the view) and the entry's
// normal from the depth's gradient.
vec4 entry_point(uint index, vec3 x, out vec3 n_entry) {
    ShadowView v = scene.views[index];
    ivec2 origin = tile_origin(index + 1u, v.tile.z);
    n_entry = vec3(0.0);
    vec4 clip = v.view_proj * vec4(x, 1.0);
    if (clip.w <= 0.0) {
        return vec4(0.0);
    }
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) {
        return vec4(0.0);
    }
    mat4 inv = exit_view.entry_inverses[index];
    ivec2 t = ivec2(floor((ndc.xy * 0.5 + 0.5) * v.tile.z));
    vec4 c = stored_point(v, origin, inv, t);
    // x's own texel is empty within a texel of the light's silhouette: a neighbour's surface
    // (the caller intersects its plane with the ray, so the texel's offset does not matter).
    const ivec2 NEIGHBOURS[4] = ivec2[](ivec2(1, 0), ivec2(-1, 0), ivec2(0, 1), ivec2(0, -1));
    for (int k = 0; k < 4 && c.w == 0.0; ++k) {
        t += NEIGHBOURS[k];
        c = stored_point(v, origin, inv, t);
        if (c.w == 0.0) {
            t -= NEIGHBOURS[k];
        }
    }
    if (c.w == 0.0) {
        return vec4(0.0);
    }
    // The gradient from the one-sided differences with the smaller depth step (silhouettes jump).
    vec4 px = stored_point(v, origin, inv, t + ivec2(1, 0));
    vec4 mx = stored_point(v, origin, inv, t - ivec2(1, 0));
    vec4 py = stored_point(v, origin, inv, t + ivec2(0, 1));
    vec4 my = stored_point(v, origin, inv, t - ivec2(0, 1));
    vec3 dx = vec3(0.0);
    vec3 dy = vec3(0.0);
    if (px.w > 0.0 && (mx.w == 0.0 || distance(px.xyz, c.xyz) <= distance(mx.xyz, c.xyz))) {
        dx = px.xyz - c.xyz;
    } else if (mx.w > 0.0) {
        dx = c.xyz - mx.xyz;
    }
    if (py.w > 0.0 && (my.w == 0.0 || distance(py.xyz, c.xyz) <= distance(my.xyz, c.xyz))) {
        dy = py.xyz - c.xyz;
    } else if (my.w > 0.0) {
        dy = c.xyz - my.xyz;
    }
    vec3 g = cross(dx, dy);
    n_entry = length(g) > 0.0 ? normalize(g) : vec3(0.0);
    float texel = v.tile.w + v.eye.w * distance(c.xyz, v.eye.xyz);
    return vec4(c.xyz, max(texel, 1e-9));
}

// Fraction of the 3x3 texels around p's projection whose depth is behind p: 1 = lit (gather_q.comp).
float visibility(uint index, vec3 p, vec3 n, float cos_l) {
    ShadowView v = scene.views[index];
    float texel = v.tile.w + v.eye.w * distance(p, v.eye.xyz);
    float sin_l = sqrt(max(1.0 - cos_l * cos_l, 0.0));
    vec4 clip = v.view_proj * vec4(p + n * (pc.normal_offset * texel * sin_l), 1.0);
    if (clip.w <= 0.0) {
        return 1.0;
    }
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) {
        return 1.0;
    }
    float size = v.tile.z;
    ivec2 origin = ivec2(v.tile.xy);
    ivec2 centre = ivec2(floor((ndc.xy * 0.5 + 0.5) * size));
    float depth = clamp(ndc.z, 0.0, 1.0);
    float lit = 0.0;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            ivec2 t = clamp(centre + ivec2(dx, dy), ivec2(0), ivec2(size) - 1);
            lit += depth <= texelFetch(shadow_atlas, origin + t, 0).r ? 1.0 : 0.0;
        }
    }
    return lit / 9.0;
}

// Direction towards light i from p, its irradiance there (on a surface facing it), and its view.
vec3 arriving(GatherLight light, vec3 p, out vec3 l) {
    uint kind = uint(light.position.w);
    if (kind == LIGHT_DIRECTIONAL) {
        l = -light.position.xyz;
        return light.colour.rgb;
    }
    vec3 to_light = light.position.xyz - p;
    float r = max(length(to_light), 1e-9);
    l = to_light / r;
    float falloff = 1.0;
    if (kind == LIGHT_SPOT) {
        float cos_axis = dot(-l, light.direction.xyz);
        float co = light.direction.w;
        float ci = light.colour.w;
        if (ci - co > 1e-12) {
            float s = clamp((cos_axis - co) / (ci - co), 0.0, 1.0);
            falloff = s * s * (3.0 - 2.0 * s);
        } else {
            falloff = cos_axis >= co ? 1.0 : 0.0;
        }
    }
    return light.colour.rgb * falloff / r / r;
}

uint view_of(GatherLight light, vec3 l) {
    return light.views.y == 6u ? light.views.x + cube_face(-l) : light.views.x;
}

// Whether x lies in front of the nearest back face the eye sees along its pixel (inside the
// object's first layer, for a point behind the front surface); a pixel with no back face is
// outside the silhouette.
bool before_far_face(vec3 x) {
    vec4 clip = exit_view.view_proj * vec4(x, 1.0);
    if (clip.w <= 0.0) {
        return false;
    }
    vec3 ndc = clip.xyz / clip.w;
    if (any(greaterThan(abs(ndc.xy), vec2(1.0)))) {
        return false;
    }
    float size = exit_view.tile.z;
    ivec2 origin = ivec2(exit_view.tile.xy);
    vec2 f = (ndc.xy * 0.5 + 0.5) * size;
    ivec2 t = clamp(ivec2(floor(f)), ivec2(0), ivec2(size) - 1);
    float back = texelFetch(depths, origin + t, 0).r;
    // Between four drawn texel centres the depth of a plane is bilinear in the tile (NDC depth is
    // affine in screen space): near the silhouette the far face is steep, and a texel's one
    // depth is off by many texels of distance.
    vec2 g = f - 0.5;
    ivec2 c = clamp(ivec2(floor(g)), ivec2(0), ivec2(size) - 2);
    vec2 a = clamp(g - vec2(c), 0.0, 1.0);
    float d00 = texelFetch(depths, origin + c, 0).r;
    float d10 = texelFetch(depths, origin + c + ivec2(1, 0), 0).r;
    float d01 = texelFetch(depths, origin + c + ivec2(0, 1), 0).r;
    float d11 = texelFetch(depths, origin + c + ivec2(1, 1), 0).r;
    if (max(max(d00, d10), max(d01, d11)) < 1.0) {
        back = mix(mix(d00, d10, a.x), mix(d01, d11, a.x), a.y);
    }
    // Depth is monotonic along the eye's rays: compare it directly.
    return back < 1.0 && ndc.z < back;
}

// The search stops past the depth where the untruncated exponential keeps this much mass: every
// sample lies before it (the deepest at ln(2 samples) / sigma < ln(1 / EXIT_SEARCH_MASS) /
// sigma), so an exit further on moves the truncated mass, the depths and their weights by less
// than this (a tenth of single_scattering::DARK_LIGHT_FRACTION, the pass's error budget).
const float EXIT_SEARCH_MASS = 1e-4;

// The distance along the refracted view ray (from `start`, direction w) to the far face: the
// first step of EXIT_STEPS (up to `far`, the bounding sphere's chord) whose point has left,
// refined by bisection; `far` if none leaves, or none leaves before `cut` (EXIT_SEARCH_MASS:
// the same steps, the rest not looked at).
float exit_distance(vec3 start, vec3 w, float far, float cut) {
    float inside = 0.0;
    for (int j = 1; j <= EXIT_STEPS && inside < cut; ++j) {
        float f = float(j) / float(EXIT_STEPS);
        float t = far * f * f;
        if (!before_far_face(start + w * t)) {
            float outside = t;
            for (int b = 0; b < EXIT_BISECTIONS; ++b) {
                float mid = 0.5 * (inside + outside);
                if (before_far_face(start + w * mid)) {
                    inside = mid;
                } else {
                    outside = mid;
                }
            }
            return 0.5 * (inside + outside);
        }
        inside = t;
    }
    return far;
}

float refracted_cosine(float eta, float mu) {
    return sqrt(max(1.0 - (1.0 - mu * mu) / (eta * eta), 0.0));
}

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.vertex_count) {
        return;
    }
    vec3 x = vertex_vec3(v, 0u);
    vec3 n = vertex_vec3(v, 3u);
    vec3 sum = vec3(0.0);
    float eta = pc.sigma_s.w;
    vec3 to_eye = pc.eye.xyz - x;
    n = length(n) > 0.0 ? normalize(n) : vec3(0.0);
    to_eye = length(to_eye) > 0.0 ? normalize(to_eye) : vec3(0.0);
    float mu_o = dot(n, to_eye);
    if (mu_o <= 0.0 || pc.samples == 0u || pc.mode == 0u) {
        scattered.x[v] = vec4(0.0);
        return;
    }
    // Refracted view ray into the medium (solver::transport::refract_inward).
    float cos_t = refracted_cosine(eta, mu_o);
    vec3 w = (-to_eye + n * mu_o) / eta - n * cos_t;
    w = length(w) > 0.0 ? normalize(w) : -n;
    float mu_o_inside = -dot(w, n);
    vec3 start = x - n * pc.sigma_a.w;
    // The coefficients below the vertex set the stratification and the flat closed form's
    // albedo (as the f64 reference's `here`); each depth scatters with its own sigma_s'.
    vec3 here_s;
    vec3 here_a;
    coefficients_at(start, here_s, here_a);
    vec3 sigma_t = here_s + here_a;
    float sigma_ref = (sigma_t.r + sigma_t.g + sigma_t.b) / 3.0;
    uint count = min(scene.counts.x, MAX_LIGHTS);
    // The far face (DESIGN 2.8): the march stops there. Without an eye view (the eye inside the
    // bounding sphere) it runs on [0, infinity) and samples past the far face see a long
    // optical path or no light.
    if (pc.mode == 3u) {
        // No light above the error budget: the environment's closed form alone, no march.
        vec3 env = environment_single_scattering(n, here_s / sigma_t, mu_o_inside, eta);
        vec3 out_env = PI * env;
        out_env = mix(out_env, vec3(0.0), isnan(out_env));
        out_env = mix(out_env, vec3(0.0), isinf(out_env));
        scattered.x[v] = vec4(out_env, 0.0);
        return;
    }
    float t_max = 1.0 / 0.0;
    vec4 bounds = exit_view.bounds;
    if (exit_view.tile.z > 0.0) {
        // The chord of the bounding sphere along w from start bounds the search.
        vec3 oc = start - bounds.xyz;
        float b = dot(oc, w);
        float c = dot(oc, oc) - bounds.w * bounds.w;
        float far = -b + sqrt(max(b * b - c, 0.0));
        float cut = -log(EXIT_SEARCH_MASS) / sigma_ref;
        t_max = exit_distance(start, w, max(far, 0.0), cut);
    }
    // Stratified in the exponential's cumulative distribution truncated at t_max (mass of the
    // untruncated exponential below t_max).
    float mass = isinf(t_max) ? 1.0 : 1.0 - exp(-sigma_ref * t_max);
    for (uint k = 0u; k < pc.samples && mass > 0.0; ++k) {
        float u = (float(k) + 0.5) / float(pc.samples);
        float t = -log(1.0 - u * mass) / sigma_ref;
        float weight = mass / (float(pc.samples) * sigma_ref * (1.0 - u * mass)); // 1 / (N pdf)
        vec3 xk = start + w * t;
        vec3 tau_v = optical_depth(start, xk);
        if (all(greaterThan(tau_v, vec3(MAX_OPTICAL_DEPTH)))) {
            continue;
        }
        vec3 sigma_s;
        vec3 sigma_a_k;
        coefficients_at(xk, sigma_s, sigma_a_k);
        for (uint i = 0u; i < count; ++i) {
            GatherLight light = scene.lights[i];
            if (light.views.y == 0u || all(equal(light.colour.rgb, vec3(0.0)))) {
                // An unshadowed light has no entry points to read; a black one (or one below
                // the error budget, blackened by the pass) adds nothing.
                continue;
            }
            vec3 l;
            arriving(light, xk, l);
            vec3 n_i;
            vec4 entry = entry_point(view_of(light, l), xk, n_i);
            if (entry.w == 0.0) {
                continue;
            }
            vec3 l_entry;
            vec3 e = arriving(light, entry.xyz, l_entry);
            // Facing the light by construction; a reconstructed normal that says otherwise
            // (a silhouette texel) is taken as grazing.
            float mu_i = clamp(dot(n_i, l_entry), 0.0, 1.0);
            if (length(n_i) == 0.0) {
                mu_i = 1.0;
            }
            float mu_t = max(refracted_cosine(eta, mu_i), MIN_MU_T);
            float t_i = fresnel_transmittance(eta, mu_i);
            // The distance to the entry along the light's ray (a texel centre is up to half a
            // texel off the ray): the ray's crossing of the entry's tangent plane: a texel centre on a steep
            // (grazing) surface lies far off the ray in depth; its plane does not.
            float along = length(n_i) > 0.0 && mu_i > MIN_PLANE_COSINE
                ? dot(entry.xyz - xk, n_i) / mu_i
                : dot(entry.xyz - xk, l);
            if (along < -entry.w) {
                continue; // in front of the first surface: outside, on the light's side
            }
            float s = max(along, 0.0); // within a texel of the entry: the depth's resolution
            // Jensen's refraction correction of the light-side distance s_i' = s_i mu_i / mu_t.
            // Through the material from x_k to the entry's plane along the light (a homogeneous
            // material: sigma_t' s exactly).
            vec3 tau = optical_depth(xk, xk + l * s) * (mu_i / mu_t) + tau_v;
            vec3 fluence = e * (mu_i * t_i / mu_t);
            vec3 term = sigma_s / (4.0 * PI) * fluence * exp(-min(tau, vec3(MAX_OPTICAL_DEPTH))) * weight;
            sum += mix(term, vec3(0.0), greaterThan(tau, vec3(MAX_OPTICAL_DEPTH)));
        }
    }
    if (pc.mode == 1u) {
        vec3 albedo = here_s / sigma_t;
        for (uint i = 0u; i < count; ++i) {
            GatherLight light = scene.lights[i];
            vec3 l;
            vec3 e = arriving(light, x, l);
            float mu_i = dot(n, l);
            if (mu_i <= 0.0 || all(equal(e, vec3(0.0)))) {
                continue;
            }
            float vis = 1.0;
            if (light.views.y > 0u) {
                vis = visibility(view_of(light, l), x, n, mu_i);
            }
            float mu_t = refracted_cosine(eta, mu_i);
            float t_i = fresnel_transmittance(eta, mu_i);
            // DESIGN 2.8's flat closed form without T_o / eta^2 (transport::flat_single_scattering).
            sum -= vis * albedo / (4.0 * PI) * e * mu_i * t_i / max(mu_t + mu_o_inside, MIN_MU_T);
        }
    }
    if (pc.mode == 2u) {
        sum += environment_single_scattering(n, here_s / sigma_t, mu_o_inside, eta);
    }
    vec3 out_x = PI * sum;
    // No NaN/Inf leaves the pass (a degenerate normal or an overflowing light).
    out_x = mix(out_x, vec3(0.0), isnan(out_x));
    out_x = mix(out_x, vec3(0.0), isinf(out_x));
    scattered.x[v] = vec4(out_x, 0.0);
}
