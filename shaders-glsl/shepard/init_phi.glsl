// Initial phi of a level (paper section 4.3): Shepard resampling of the coarser level's converged
// phi (paper Eq. 10), phi_i = sum_k w_ik phi_coarse(link_ik) / sum_k w_ik. Each link is one packed
// u32 (links.glsl: coarse texel index and an 8-bit weight); the weights are renormalized here so
// that their rounding cannot scale phi. With `zero` set (coarsest level, no warm start) phi starts
// at 0. Included with PHI_FORMAT set to the state format.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, PHI_FORMAT) uniform readonly image2D coarse;
layout(set = 0, binding = 1, PHI_FORMAT) uniform writeonly image2D dst;
layout(set = 0, binding = 2, rgba32ui) uniform readonly uimage2D links_lo;
layout(set = 0, binding = 3, rgba32ui) uniform readonly uimage2D links_hi;

#include "links.glsl"

layout(push_constant) uniform ShepardPush {
    ivec2 size;
    uint coarse_width;
    uint zero;
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    vec3 phi = vec3(0.0);
    if (pc.zero == 0u) {
        uvec4 l[2] = uvec4[2](imageLoad(links_lo, p), imageLoad(links_hi, p));
        float total = 0.0;
        for (int h = 0; h < 2; ++h) {
            for (int k = 0; k < 4; ++k) {
                uint c = link_texel(l[h][k]);
                float w = link_weight(l[h][k]);
                ivec2 t = ivec2(int(c % pc.coarse_width), int(c / pc.coarse_width));
                phi += w * imageLoad(coarse, t).rgb;
                total += w;
            }
        }
        // Padding and unlinked texels have all weights 0: they stay 0.
        phi = total > 0.0 ? phi / total : vec3(0.0);
    }
    imageStore(dst, p, vec4(phi, 0.0));
}
