#version 460
// The radiance volume (paper section 2.2; solver::voxel::ExitPass): per solid voxel the outgoing
// partial current J+ the optical path gives,
//   paper:      J+ = exp(-n)                         (the paper's L = F_t exp(-n), Eq. 1, read as
//                                                     L = F_t J+ / (pi eta^2): see the module doc)
//   diffusion:  J+ = C exp(-n) l / (l + d)           (n along sigma_tr, d the path's length)
// with C = albedo(semi-infinite, uniform light) / (1 - F_dr), so a uniformly lit flat surface
// returns DESIGN section 2's diffusion albedo, and l = spread / sigma_t' (the 1/d spreading from a
// source; spread = 0 turns it off). Stored premultiplied by coverage (rgb J+, a = 1; empty voxels
// 0): the trilinear read at the surface (vertex_exitance.comp) divides by a, so empty voxels
// outside do not darken it.
#include "voxel_grid.glsl"
#include "optics.glsl"

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
    float spread;        // diffusion: l = spread / sigma_t'; 0: no spreading
    uint pad;
} pc;

// exp(-n) never overflows: n0 >= -ln(1e30 * ...) stays above this for every accepted light.
const float MIN_N = -80.0;

void main() {
    ivec3 v = ivec3(gl_GlobalInvocationID);
    if (!in_grid(v, pc.dims.xyz)) {
        return;
    }
    vec4 value = vec4(0.0);
    if (imageLoad(medium, v).a != 0.0) {
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
            vec3 s = sqrt(3.0 * sigma_a * sigma_t);
            float f_dr = diffuse_reflectance(pc.eta);
            float big_a = (1.0 + f_dr) / (1.0 - f_dr);
            vec3 d = imageLoad(path, v).rgb;
            for (int c = 0; c < 3; ++c) {
                // DESIGN section 2, semi-infinite medium under uniform light; D = 1 / (3 sigma_t').
                float diffusion = sigma_t[c] > 0.0 ? 1.0 / (3.0 * sigma_t[c]) : 0.0;
                float albedo = (2.0 / (1.0 + 2.0 * big_a * diffusion * s[c]) - (1.0 - f_dr)) / (1.0 + f_dr);
                float gain = max(albedo, 0.0) / (1.0 - f_dr);
                float spread = 1.0;
                if (pc.spread > 0.0 && sigma_t[c] > 0.0) {
                    float l = pc.spread / sigma_t[c];
                    spread = l / (l + d[c]);
                }
                j[c] *= gain * spread;
            }
        }
        value = vec4(j, 1.0);
    }
    imageStore(exit_volume, v, value);
}
