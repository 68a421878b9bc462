// Outgoing partial current at the surface nodes (DESIGN section 2 and 2.6): the shading input
// X = phi_factor phi - q_factor q (+ particular_factor times the collimated source's part, 2.7):
// J+ = (1 + 1/A) phi / 4 - q / (1 + F_dr) for the flux query, M eta^2 / (1 - 2 C1(1/eta)) for the
// moments query (`Boundary::flux_shading_factors`), unscaled from the exposure (phi and q are stored times
// q_scale), clamped at 0 for display; clamped nodes are counted per channel. Surface nodes are the
// rows v < surface_rows that are not padding (padding texels point to themselves). Alpha: the
// node's diffused share for the per-node exit lobe (scene::diffused_share; 0 off the surface).
// Included with PHI_FORMAT set.
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
    float flux_gain; // Robin right-hand side per unit q (transport::Boundary::flux_gain)
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    uint self_index = uint(p.y) * uint(pc.size.x) + uint(p.x);
    bool surface = uint(p.y) < pc.surface_rows && imageLoad(connectivity, p).x != self_index;
    vec3 j = vec3(0.0);
    float share = 0.0;
    if (surface) {
        vec3 phi_h = imageLoad(phi, p).rgb;
        vec3 q_h = imageLoad(q, p).rgb;
        vec3 homogeneous = pc.phi_factor * phi_h - pc.q_factor * q_h;
        vec3 scaled = homogeneous;
        if (pc.particular_factor != 0.0) {
            scaled += pc.particular_factor * imageLoad(particular, p).rgb;
        }
        // The diffused share (scene::diffused_share): per channel the homogeneous field's P1
        // share 1 - rhs / phi, weighted by its exitance against the node's.
        float diffused = 0.0;
        float total = 0.0;
        for (int c = 0; c < 3; ++c) {
            float p1 = phi_h[c] > 0.0 ? clamp(1.0 - pc.flux_gain * q_h[c] / phi_h[c], 0.0, 1.0) : 0.0;
            float m = max(scaled[c], 0.0);
            diffused += p1 * clamp(homogeneous[c], 0.0, m);
            total += m;
        }
        share = total > 0.0 ? clamp(diffused / total, 0.0, 1.0) : 0.0;
        share = isnan(share) || isinf(share) ? 0.0 : share;
        vec3 raw = scaled * pc.inv_q_scale;
        for (int c = 0; c < 3; ++c) {
            if (!(raw[c] >= 0.0)) {
                atomicAdd(counts.clamped[c], 1u);
                raw[c] = 0.0;
            }
        }
        j = raw;
    }
    imageStore(j_plus, p, vec4(j, share));
}
