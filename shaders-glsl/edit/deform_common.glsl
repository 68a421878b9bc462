// Shared by the deformation passes: a tetrahedron's deformed and rest edge matrices and the
// normal transform n' ~ F^-T n of its deformation gradient F = D' D^-1 (D = [v1-v0, v2-v0, v3-v0]):
// F^-T = D'^-T D^T, and M^-T y = ((b x c) y0 + (c x a) y1 + (a x b) y2) / det M for M = [a b c].
#ifndef DEFORM_COMMON_GLSL
#define DEFORM_COMMON_GLSL

vec3 transform_normal(vec3 r0, vec3 r1, vec3 r2, vec3 r3, vec3 d0, vec3 d1, vec3 d2, vec3 d3, vec3 n) {
    vec3 a = d1 - d0;
    vec3 b = d2 - d0;
    vec3 c = d3 - d0;
    vec3 y = vec3(dot(r1 - r0, n), dot(r2 - r0, n), dot(r3 - r0, n));
    vec3 m = cross(b, c) * y.x + cross(c, a) * y.y + cross(a, b) * y.z;
    // The sign of det D' keeps the normal outward; the length is normalized away.
    float det = dot(a, cross(b, c));
    m *= det < 0.0 ? -1.0 : 1.0;
    float len = length(m);
    // A flattened tetrahedron (det -> 0) keeps the rest normal rather than a NaN.
    return len > 0.0 && !isinf(len) ? m / len : n;
}

#endif
