// One view of the reflective shadow maps (solver::voxel::rsm::RsmView, std430) and the light it
// belongs to; the light's irradiance as solver::Light::arriving computes it.
#ifndef RSM_VIEW_GLSL
#define RSM_VIEW_GLSL

const uint RSM_MAX_VIEWS = 48;
const uint RSM_LIGHT_DIRECTIONAL = 0;
const uint RSM_LIGHT_POINT = 1;
const uint RSM_LIGHT_SPOT = 2;

struct RsmView {
    mat4 view_proj;
    vec4 eye;            // xyz: eye (perspective views); w: 1 perspective, 0 orthographic
    vec4 axis;           // xyz: view axis (perspective); w: texel size: mm (orthographic), or per
                         // mm of distance on the unit image plane (perspective)
    vec4 light_position; // xyz: position, or direction of travel (directional); w: kind
    vec4 light_axis;     // xyz: spot axis (unit); w: cos(outer)
    vec4 colour;         // rgb: irradiance (directional) or intensity; w: cos(inner)
    uvec4 tile;          // xy: atlas texel origin, z: tile size, w: light index
};

// Irradiance arriving at p on a surface facing the light, and the unit direction l towards it
// (solver::Light::arriving: 1/r^2, the spot's smoothstep in cos between its cone angles).
vec3 light_arriving(RsmView view, vec3 p, out vec3 l) {
    uint kind = uint(view.light_position.w);
    if (kind == RSM_LIGHT_DIRECTIONAL) {
        l = -normalize(view.light_position.xyz);
        return view.colour.rgb;
    }
    vec3 to_light = view.light_position.xyz - p;
    float r = max(length(to_light), 1e-9);
    l = to_light / r;
    float falloff = 1.0;
    if (kind == RSM_LIGHT_SPOT) {
        float cos_axis = dot(-l, view.light_axis.xyz);
        float ci = view.colour.w;
        float co = view.light_axis.w;
        if (ci - co > 1e-12) {
            float t = clamp((cos_axis - co) / (ci - co), 0.0, 1.0);
            falloff = t * t * (3.0 - 2.0 * t);
        } else {
            falloff = cos_axis >= co ? 1.0 : 0.0;
        }
    }
    return view.colour.rgb * (falloff / (r * r));
}

// The area (mm^2) of the texel's footprint perpendicular to the light at p: the texel size squared
// for an orthographic view; for a perspective one its solid angle s^2 cos^3(alpha) times r^2.
float texel_area(RsmView view, vec3 p) {
    if (view.eye.w == 0.0) {
        return view.axis.w * view.axis.w;
    }
    vec3 d = p - view.eye.xyz;
    float r2 = dot(d, d);
    float cos_alpha = r2 > 0.0 ? dot(view.axis.xyz, d) * inversesqrt(r2) : 1.0;
    float c = max(cos_alpha, 0.0);
    return view.axis.w * view.axis.w * c * c * c * r2;
}

#endif
