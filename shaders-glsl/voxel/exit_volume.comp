#version 460
// The radiance volume (paper section 2.2; solver::voxel::ExitPass): per solid voxel the outgoing
// partial current J+ the optical path gives, M = (1 - F_dr) J+ leaving into air:
//   paper:      J+ = exp(-n)                 (the paper's L = F_t exp(-n), Eq. 1, read as
//                                             L = F_t J+ / (pi eta^2): see the module doc)
//   diffusion:  M  = exp(-n) G(d)            n along sigma_tr = sqrt(3 sigma_a sigma_t'),
//                                             d the path's length (mm), G: diffusion_profile.glsl
// R is DESIGN section 2's albedo of a semi-infinite medium under uniform light, and
// P(d) exp(-sigma_tr d) its transmittance T of a slab of thickness d lit on one face:
//   P(d) = 8 D s / ((1 - F_dr) [(1 + h s)^2 - (1 - h s)^2 exp(-2 s d)]),  s = sigma_tr, h = 2 A D,
// G(d) = P(d) + (R - P(0)) exp(-d / (2 h)) - B(d): a uniformly lit flat face returns R q, and the
// far face of a lit slab T(d) q less its unscattered part B: the diffusion falloff along the path,
// with its 1/d spreading (P -> 4 D / ((1 - F_dr)(2 h + d)) when s d << 1).
// Stored premultiplied by coverage (rgb J+, a = 1) in the surface shell only (solid voxels next to
// an empty one, where the injection starts the light); empty and interior voxels hold 0, so the
// trilinear read at the surface (vertex_exitance.comp, which divides by a) sees neither the air
// outside nor the deeper voxels behind the shell, whose share of a vertex's 8 neighbours varies
// with where the vertex falls in the grid (a voxel-scale pattern, issue 14).
#include "voxel_grid.glsl"
#include "optics.glsl"
#include "diffusion_profile.glsl"

layout(local_size_x = 4, local_size_y = 4, local_size_z = 4) in;

layout(set = 0, binding = 0, std430) readonly buffer Grid { GridFrame grid; } grid;
layout(set = 0, binding = 1, rgba32f) uniform readonly image3D medium;
layout(set = 0, binding = 2, rgba32f) uniform readonly image3D state;
layout(set = 0, binding = 3, rgba32f) uniform readonly image3D path;
layout(set = 0, binding = 4) uniform sampler3D sigma_s_volume;
layout(set = 0, binding = 5) uniform sampler3D sigma_a_volume;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image3D exit_volume;

layout(push_constant) uniform ExitPush {
    uvec4 dims;          // xyz: voxels per axis
    vec4 material_lo;    // xyz: the material volume's box (mm)
    vec4 material_hi;
    uint model;          // 0: paper, 1: diffusion
    float eta;
    uint pad0;
    uint pad1;
} pc;

// exp(-n) never overflows: n0 >= -ln(1e30 * ...) stays above this for every accepted light.
const float MIN_N = -80.0;

void main() {
    ivec3 v = ivec3(gl_GlobalInvocationID);
    if (!in_grid(v, pc.dims.xyz)) {
        return;
    }
    vec4 value = vec4(0.0);
    bool shell = false;
    if (imageLoad(medium, v).a != 0.0) {
        for (int z = -1; z <= 1 && !shell; ++z) {
            for (int y = -1; y <= 1 && !shell; ++y) {
                for (int x = -1; x <= 1 && !shell; ++x) {
                    ivec3 u = v + ivec3(x, y, z);
                    shell = !in_grid(u, pc.dims.xyz) || imageLoad(medium, u).a == 0.0;
                }
            }
        }
    }
    if (shell) {
        vec3 n = imageLoad(state, v).rgb;
        vec3 j = vec3(0.0);
        for (int c = 0; c < 3; ++c) {
            j[c] = n[c] >= 0.5 * N_UNLIT ? 0.0 : exp(-max(n[c], MIN_N));
        }
        if (pc.model == 1u) {
            GridFrame g = grid.grid;
            vec3 extent = max(pc.material_hi.xyz - pc.material_lo.xyz, vec3(1e-30));
            vec3 uvw = clamp((voxel_centre(v, g) - pc.material_lo.xyz) / extent, 0.0, 1.0);
            vec3 sigma_s = max(texture(sigma_s_volume, uvw).rgb, vec3(0.0));
            vec3 sigma_a = max(texture(sigma_a_volume, uvw).rgb, vec3(0.0));
            vec3 sigma_t = sigma_s + sigma_a;
            vec3 d = imageLoad(path, v).rgb;
            float f_dr = diffuse_reflectance(pc.eta);
            float big_a = (1.0 + f_dr) / (1.0 - f_dr);
            for (int c = 0; c < 3; ++c) {
                float gain = 0.0;
                if (sigma_t[c] > 0.0) {
                    float diffusion = 1.0 / (3.0 * sigma_t[c]);
                    float s = sqrt(3.0 * sigma_a[c] * sigma_t[c]);
                    gain = exit_gain(diffusion, s, big_a, d[c]);
                }
                // Stored as J+ = M / (1 - F_dr).
                j[c] *= gain / (1.0 - f_dr);
            }
        }
        value = vec4(j, 1.0);
    }
    imageStore(exit_volume, v, value);
}
