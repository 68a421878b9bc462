// Warm start of a level with the coarser level's CHANGE carried up (a full-approximation step on
// the nested levels of paper section 4.3): phi_h += P(phi_{h-1,new} - phi_{h-1,prev}), where P is
// the Shepard prolongation of paper Eq. 10 (packed links, weights renormalized here, as in init_phi.glsl) and
// phi_{h-1,prev} the coarser level's solution of the previous solve, saved by this same pass when
// the coarser level was warm-started. A moving light changes phi on the scale of the object; the
// finer level's own Jacobi damps such smooth error slowest, the coarser level cheaply, so only the
// change's fine detail is left to iterate.
// Flags: bit 0 (`CORRECT`) adds the coarse change; bit 1 (`SAVE`) first copies this level's phi
// (before the correction) into `saved`, for the next finer level's correction after this level
// iterates. Each texel reads and writes only its own phi, so the update is in place.
// Included with PHI_FORMAT set to the state format.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, PHI_FORMAT) uniform image2D phi;
layout(set = 0, binding = 1, PHI_FORMAT) uniform writeonly image2D saved;
layout(set = 0, binding = 2, PHI_FORMAT) uniform readonly image2D coarse_new;
layout(set = 0, binding = 3, PHI_FORMAT) uniform readonly image2D coarse_prev;
layout(set = 0, binding = 4, rgba32ui) uniform readonly uimage2D links_lo;
layout(set = 0, binding = 5, rgba32ui) uniform readonly uimage2D links_hi;

#include "links.glsl"

layout(push_constant) uniform WarmPush {
    ivec2 size;
    uint coarse_width;
    uint flags;
} pc;

const uint CORRECT = 1u;
const uint SAVE = 2u;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    vec4 old = imageLoad(phi, p);
    if ((pc.flags & SAVE) != 0u) {
        imageStore(saved, p, old);
    }
    if ((pc.flags & CORRECT) == 0u) {
        return;
    }
    uvec4 l[2] = uvec4[2](imageLoad(links_lo, p), imageLoad(links_hi, p));
    vec3 change = vec3(0.0);
    float total = 0.0;
    for (int h = 0; h < 2; ++h) {
        for (int k = 0; k < 4; ++k) {
            uint c = link_texel(l[h][k]);
            float w = link_weight(l[h][k]);
            ivec2 t = ivec2(int(c % pc.coarse_width), int(c / pc.coarse_width));
            change += w * (imageLoad(coarse_new, t).rgb - imageLoad(coarse_prev, t).rgb);
            total += w;
        }
    }
    // Padding and unlinked texels have all weights 0: they keep their phi.
    if (total > 0.0) {
        imageStore(phi, p, vec4(old.rgb + change / total, old.a));
    }
}
