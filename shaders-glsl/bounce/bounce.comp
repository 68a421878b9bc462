#version 460
// Bounces of exitance between display vertices (issue 12 item 5; engine/src/frame/bounce.rs):
// light that leaves the surface at y crosses the air (eta = 1 outside) and enters it again at x.
// mode 0 (gather): E_b(x) = sum_y F(x, y) X(y) over x's sparse links (F the form factor from the
//   bake's ray casts, X the display vertex's exitance value, floats [v * stride + offset, +3)).
// mode 2 (first gather): the same, and X(x) saved as X_0(x), the method's exitance.
// mode 1 (local): X(x) = X_0(x) + R(x) E_b(x) + T(x) E_b(x'), R and T a slab's diffuse
//   reflectance and transmittance at x's wall thickness (the half-space's R_d and 0 where the
//   wall is thick), x' where x's inward normal leaves the object (the far face of a thin wall:
//   the light re-entering there leaves here). X and the shading's exitance share one scale, so
//   F, R and T need no unit conversion.
// One bounce is modes 2, 1; each further bounce 0, 1 (Jacobi on X = X_0 + R_d F X: light that
// re-entered leaves again and reaches other vertices, a concave corner's interreflection).
layout(local_size_x = 64) in;

layout(set = 0, binding = 0, std430) buffer Vertices { float data[]; } vertices;
// Links of vertex v: links[offsets[v] .. offsets[v + 1]), x the source vertex, y the form factor's bits.
layout(set = 0, binding = 1, std430) readonly buffer Offsets { uint data[]; } offsets;
layout(set = 0, binding = 2, std430) readonly buffer Links { uvec2 data[]; } links;
// [0, count): R per vertex; [count, 2 count): T per vertex.
layout(set = 0, binding = 3, std430) readonly buffer Reflectance { vec4 data[]; } reflectance;
// [0, count): E_b per vertex; [count, 2 count): X_0, the exitance before any bounce.
layout(set = 0, binding = 4, std430) buffer Irradiance { vec4 data[]; } irradiance;
// [0, count): the far triangle's corners x'_i of vertex v; [count, 2 count): their weights' bits.
layout(set = 0, binding = 5, std430) readonly buffer Across { uvec4 data[]; } across;

layout(push_constant) uniform BouncePush {
    uint count;
    uint stride;
    uint offset;
    uint mode;
} pc;

vec3 exitance(uint v) {
    uint base = v * pc.stride + pc.offset;
    return vec3(vertices.data[base], vertices.data[base + 1u], vertices.data[base + 2u]);
}

// Never a NaN, an Inf or a negative value out of the pass.
vec3 clean(vec3 x) {
    bvec3 bad = bvec3(isnan(x.r) || isinf(x.r), isnan(x.g) || isinf(x.g), isnan(x.b) || isinf(x.b));
    return max(mix(x, vec3(0.0), bad), vec3(0.0));
}

void main() {
    uint v = gl_GlobalInvocationID.x;
    if (v >= pc.count) {
        return;
    }
    if (pc.mode != 1u) {
        if (pc.mode == 2u) {
            irradiance.data[pc.count + v] = vec4(exitance(v), 0.0);
        }
        vec3 e = vec3(0.0);
        for (uint k = offsets.data[v]; k < offsets.data[v + 1u]; ++k) {
            uvec2 l = links.data[k];
            e += uintBitsToFloat(l.y) * max(exitance(l.x), vec3(0.0));
        }
        irradiance.data[v] = vec4(clean(e), 0.0);
    } else {
        uvec3 far = across.data[v].xyz;
        vec3 w = uintBitsToFloat(across.data[pc.count + v].xyz);
        vec3 e_far = w.x * irradiance.data[far.x].rgb + w.y * irradiance.data[far.y].rgb
            + w.z * irradiance.data[far.z].rgb;
        vec3 x = irradiance.data[pc.count + v].rgb + reflectance.data[v].rgb * irradiance.data[v].rgb
            + reflectance.data[pc.count + v].rgb * e_far;
        x = clean(x);
        uint base = v * pc.stride + pc.offset;
        vertices.data[base] = x.r;
        vertices.data[base + 1u] = x.g;
        vertices.data[base + 2u] = x.b;
    }
}
