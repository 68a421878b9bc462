#version 460
// Texel ownership for the light injection (frame::voxel::InjectPass; inject_light.comp gathers by
// it): one invocation per texel of each active reflective-shadow-map view writes
//   owner[t] = uvec2(the linear index of the voxel that owns the texel's surface point, or
//                    NO_OWNER for an empty texel, one facing away from the light or with no solid
//                    voxel near,
//                    floatBitsToUint(A_perp / mu_i), the surface area the texel covers (mm^2))
// so the gather compares one index per texel instead of fetching position and normal and
// searching the 26 neighbours of every texel of its window (each texel lies in the windows of tens
// of surface voxels). Ownership (unchanged): the point moved `inward` voxels inward along its
// normal lies in one voxel; if that voxel is empty (a thin or tilted wall), the nearest solid voxel
// of its 26 neighbours owns it (ties: the lower index), so no lit texel is lost and none is counted
// twice.
#include "voxel_grid.glsl"
#include "rsm_view.glsl"

layout(local_size_x = 8, local_size_y = 8, local_size_z = 1) in;

// Grazing texels: mu_i below this counts as this (their area A_perp / mu_i stays finite).
const float MIN_COS = 0.02;
const uint NO_OWNER = 0xffffffffu;

layout(set = 0, binding = 0, std430) readonly buffer Grid { GridFrame grid; } grid;
layout(set = 0, binding = 1, rgba32f) uniform readonly image3D medium;
layout(set = 0, binding = 2) uniform sampler2D rsm_position;
layout(set = 0, binding = 3) uniform sampler2D rsm_normal;
layout(set = 0, binding = 4) uniform sampler2D rsm_irradiance;
layout(set = 0, binding = 5, std430) readonly buffer RsmViews { RsmView views[RSM_MAX_VIEWS]; } rsm;
layout(set = 0, binding = 6, rg32ui) uniform writeonly uimage2D owner;

layout(push_constant) uniform OwnerPush {
    uvec4 dims;      // xyz: voxels per axis
    uint view_count;
    float inward;    // how far a texel's point moves inward to find its voxel, in voxels
    uint pad0;
    uint pad1;
} pc;

bool solid(ivec3 v) {
    return in_grid(v, pc.dims.xyz) && imageLoad(medium, v).a != 0.0;
}

// The voxel that owns the surface point p' (see the header), or (-1) if none.
ivec3 owner_of(vec3 p, GridFrame g) {
    ivec3 c = ivec3(floor((p - g.origin.xyz) / g.origin.w));
    if (solid(c)) {
        return c;
    }
    ivec3 best = ivec3(-1);
    float best_d = 3.0e38;
    for (int z = -1; z <= 1; ++z) {
        for (int y = -1; y <= 1; ++y) {
            for (int x = -1; x <= 1; ++x) {
                ivec3 u = c + ivec3(x, y, z);
                if (!solid(u)) {
                    continue;
                }
                vec3 d = voxel_centre(u, g) - p;
                float d2 = dot(d, d);
                if (d2 < best_d) {
                    best_d = d2;
                    best = u;
                }
            }
        }
    }
    return best;
}

void main() {
    uint i = gl_GlobalInvocationID.z;
    if (i >= min(pc.view_count, RSM_MAX_VIEWS)) {
        return;
    }
    RsmView view = rsm.views[i];
    ivec2 local = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(local, ivec2(int(view.tile.z))))) {
        return;
    }
    ivec2 t = ivec2(view.tile.xy) + local;
    GridFrame g = grid.grid;
    uvec2 result = uvec2(NO_OWNER, 0u);
    vec4 p = texelFetch(rsm_position, t, 0);
    vec4 n = texelFetch(rsm_normal, t, 0);
    // Empty texels, and texels facing away from the light (no transmitted flux), own nothing.
    if (p.w != 0.0 && n.w > 0.0) {
        ivec3 o = owner_of(p.xyz - n.xyz * (pc.inward * g.origin.w), g);
        if (o.x >= 0) {
            // mu_i again in f32 (the map's a is fp16: 2e-4 off at 30 degrees).
            vec3 l;
            light_arriving(view, p.xyz, l);
            float mu = dot(normalize(n.xyz), l);
            float a_perp = texelFetch(rsm_irradiance, t, 0).a;
            result = uvec2(voxel_index(o, pc.dims.xyz), floatBitsToUint(a_perp / max(mu, MIN_COS)));
        }
    }
    imageStore(owner, t, uvec4(result, 0u, 0u));
}
