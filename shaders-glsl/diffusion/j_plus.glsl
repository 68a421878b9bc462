// Outgoing partial current at the surface nodes (DESIGN section 2 and 2.6): the shading input
// X = phi_factor phi - q_factor q (+ particular_factor times the collimated source's part, 2.7):
// J+ = (1 + 1/A) phi / 4 - q / (1 + F_dr) for the flux query, M eta^2 / (1 - 2 C1(1/eta)) for the
// moments query (`Boundary::flux_shading_factors`), unscaled from the exposure (phi and q are stored times
// q_scale), clamped at 0 for display; clamped nodes are counted per channel. Surface nodes are the
// rows v < surface_rows that are not padding (padding texels point to themselves). Included with PHI_FORMAT set.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, PHI_FORMAT) uniform readonly image2D phi;
layout(set = 0, binding = 1, rgba16f) uniform readonly image2D q;
layout(set = 0, binding = 2, rgba32ui) uniform readonly uimage2D connectivity;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D j_plus;

// The collimated source's part of the exit query (DESIGN 2.7), times q_scale; surface rows only.
layout(set = 0, binding = 5, rgba16f) uniform readonly image2D particular;

layout(set = 0, binding = 4, std430) buffer ClampCounts {
    uint clamped[4];
} counts;

layout(push_constant) uniform JPlusPush {
    ivec2 size;
    uint surface_rows;
    float inv_q_scale;
    float phi_factor;
    float q_factor;
    float particular_factor; // shading input per unit exitance; 0: no collimated source
    float pad;
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    uint self_index = uint(p.y) * uint(pc.size.x) + uint(p.x);
    bool surface = uint(p.y) < pc.surface_rows && imageLoad(connectivity, p).x != self_index;
    vec3 j = vec3(0.0);
    if (surface) {
        vec3 scaled = pc.phi_factor * imageLoad(phi, p).rgb - pc.q_factor * imageLoad(q, p).rgb;
        if (pc.particular_factor != 0.0) {
            scaled += pc.particular_factor * imageLoad(particular, p).rgb;
        }
        vec3 raw = scaled * pc.inv_q_scale;
        for (int c = 0; c < 3; ++c) {
            if (!(raw[c] >= 0.0)) {
                atomicAdd(counts.clamped[c], 1u);
                raw[c] = 0.0;
            }
        }
        j = raw;
    }
    imageStore(j_plus, p, vec4(j, surface ? 1.0 : 0.0));
}
