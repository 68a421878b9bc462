#version 460
// Light injection (solver::voxel::InjectPass; paper section 2.1, Eqs. 2-3): every solid voxel next
// to an empty one gathers the reflective-shadow-map texels near it and starts the relaxation at
//   n0 = -ln(q)   per colour channel,
// where q is the irradiance transmitted into the surface in the voxel (DESIGN section 2's q =
// E max(0, n.l) F_t(eta, theta_l), visibility by the map): per light, the texels' transmitted
// flux E T_i A_perp summed and divided by the surface area they cover, A_perp / mu_i, so q does not
// depend on how the surface cuts the voxel (the paper's P = (1/N^2) sum A_i does, by up to sqrt 3);
// plus a constant environment's q_env. The paper's F_t P is our q: F_t is in the map's E T_i.
// Which texels: every lit texel whose surface point lies within `reach` voxels (KERNEL_REACH_VOXELS) of the voxel's
// centre, weighted by a smooth kernel of that distance (q is a density: its local average, not a
// share of the flux). Every voxel of the surface shell (solid, next to an empty one: centres up to
// sqrt 3 voxels deep on a tilted surface) sees the surface near it; texels whose normal points
// away from the voxel's empty neighbours (the other face of a thin part) are left out. Before, each texel had one
// owner voxel (its point moved half a voxel inward); on a tilted surface the shell voxels deeper
// than ~1.4 voxels owned no texel and started unlit, so the exit read lit and unlit voxels side by
// side: the mottling at the voxel scale (issue 14).
// Voxels with no light start at N_UNLIT; every voxel's state and path length are initialised.
#include "voxel_grid.glsl"
#include "rsm_view.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

// Grazing texels: mu_i below this counts as this (their area A_perp / mu_i stays finite).
const float MIN_COS = 0.02;
// The gather's half-width in texels is capped (a map far coarser than the voxels).
const int MAX_TEXEL_RADIUS = 24;

layout(set = 0, binding = 0, std430) readonly buffer Grid { GridFrame grid; } grid;
layout(set = 0, binding = 1, rgba32f) uniform readonly image3D medium;
layout(set = 0, binding = 2) uniform sampler2D rsm_position;
layout(set = 0, binding = 3) uniform sampler2D rsm_normal;
layout(set = 0, binding = 4) uniform sampler2D rsm_irradiance;
layout(set = 0, binding = 5, std430) readonly buffer RsmViews { RsmView views[RSM_MAX_VIEWS]; } rsm;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image3D seed;
layout(set = 0, binding = 7, rgba32f) uniform writeonly image3D state;
layout(set = 0, binding = 8, rgba32f) uniform writeonly image3D path;

layout(push_constant) uniform InjectPush {
    uvec4 dims;     // xyz: voxels per axis
    vec4 env_q;     // rgb: transmitted irradiance of a constant environment, at every surface voxel
    uint view_count;
    float reach;    // the kernel's radius, in voxels
    uint track_path; // 1: initialise the path lengths too (the diffusion model)
    uint pad;
} pc;

bool solid(ivec3 v) {
    return in_grid(v, pc.dims.xyz) && imageLoad(medium, v).a != 0.0;
}

void main() {
    ivec3 v = ivec3(gl_GlobalInvocationID);
    if (!in_grid(v, pc.dims.xyz)) {
        return;
    }
    GridFrame g = grid.grid;
    float h = g.origin.w;
    vec3 n0 = vec3(N_UNLIT);
    bool surface = false;
    // Towards the air: the sum of the offsets to the empty neighbours.
    vec3 outward = vec3(0.0);
    if (solid(v)) {
        for (int z = -1; z <= 1; ++z) {
            for (int y = -1; y <= 1; ++y) {
                for (int x = -1; x <= 1; ++x) {
                    ivec3 o = ivec3(x, y, z);
                    if (!solid(v + o)) {
                        surface = true;
                        outward += vec3(o) / edge_factor(o);
                    }
                }
            }
        }
    }
    if (surface) {
        vec3 centre = voxel_centre(v, g);
        float reach = pc.reach * h;
        vec3 q = pc.env_q.rgb;
        vec3 flux = vec3(0.0);
        float area = 0.0;
        for (uint i = 0; i < min(pc.view_count, RSM_MAX_VIEWS); ++i) {
            RsmView view = rsm.views[i];
            vec4 clip = view.view_proj * vec4(centre, 1.0);
            if (clip.w > 0.0) {
                vec2 ndc = clip.xy / clip.w;
                float size = float(view.tile.z);
                float texel = view.eye.w == 0.0
                    ? view.axis.w
                    : view.axis.w * max(dot(centre - view.eye.xyz, view.axis.xyz), 1e-6);
                // A texel within the kernel lies within `reach` of the centre, its texel within
                // that distance (over the texel size) of the centre's texel.
                int radius = min(int(ceil(reach / max(texel, 1e-30))) + 1, MAX_TEXEL_RADIUS);
                ivec2 centre_texel = ivec2(floor((ndc * 0.5 + 0.5) * size));
                ivec2 lo = max(centre_texel - radius, ivec2(0));
                ivec2 hi = min(centre_texel + radius, ivec2(int(size) - 1));
                for (int ty = lo.y; ty <= hi.y; ++ty) {
                    for (int tx = lo.x; tx <= hi.x; ++tx) {
                        ivec2 t = ivec2(view.tile.xy) + ivec2(tx, ty);
                        vec4 p = texelFetch(rsm_position, t, 0);
                        if (p.w == 0.0) {
                            continue;
                        }
                        vec3 to_centre = p.xyz - centre;
                        float r2 = dot(to_centre, to_centre) / (reach * reach);
                        if (r2 >= 1.0) {
                            continue;
                        }
                        vec4 n = texelFetch(rsm_normal, t, 0);
                        if (n.w <= 0.0) {
                            continue; // facing away from the light: no transmitted flux
                        }
                        if (dot(n.xyz, outward) <= 0.0) {
                            continue; // the other face of a part thinner than the kernel
                        }
                        // mu_i again in f32 (the map's a is fp16: 2e-4 off at 30 degrees).
                        vec3 l;
                        light_arriving(view, p.xyz, l);
                        float mu = dot(normalize(n.xyz), l);
                        vec4 e = texelFetch(rsm_irradiance, t, 0);
                        // The kernel: smooth, 1 at the centre, 0 with zero slope at the reach.
                        float w = (1.0 - r2) * (1.0 - r2);
                        flux += w * e.rgb * e.a;
                        area += w * e.a / max(mu, MIN_COS);
                    }
                }
            }
            bool last_of_light = i + 1u >= pc.view_count || rsm.views[i + 1u].tile.w != view.tile.w;
            if (last_of_light) {
                if (area > 0.0) {
                    q += flux / area;
                }
                flux = vec3(0.0);
                area = 0.0;
            }
        }
        for (int c = 0; c < 3; ++c) {
            // Eq. 2: n0 = -ln(F_t P), F_t P = q.
            n0[c] = q[c] > 0.0 ? -log(q[c]) : N_UNLIT;
        }
    }
    imageStore(seed, v, vec4(n0, 0.0));
    imageStore(state, v, vec4(n0, 0.0));
    if (pc.track_path != 0u) {
        imageStore(path, v, vec4(0.0));
    }
}
