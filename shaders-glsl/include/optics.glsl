// Fresnel terms of a smooth dielectric boundary (DESIGN section 2). eta = n_inside / n_outside.
#ifndef OPTICS_GLSL
#define OPTICS_GLSL

const float PI = 3.14159265358979;

// Fresnel reflectance of unpolarized light arriving from outside at cos_i (exact, both polarizations).
float fresnel_reflectance(float eta, float cos_i) {
    cos_i = clamp(cos_i, 0.0, 1.0);
    float sin_t2 = (1.0 - cos_i * cos_i) / (eta * eta);
    if (sin_t2 >= 1.0) {
        return 1.0; // total internal reflection (eta < 1 only)
    }
    float cos_t = sqrt(1.0 - sin_t2);
    float rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    float rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    return 0.5 * (rs * rs + rp * rp);
}

// F_t(eta, theta): transmittance, equal in both directions by reciprocity.
float fresnel_transmittance(float eta, float cos_theta) {
    return 1.0 - fresnel_reflectance(eta, cos_theta);
}

// F_dr(eta): internal diffuse Fresnel reflectance (DESIGN section 2); the polynomial fit for
// eta >= 1, Egan and Hilgeman's for eta < 1, as `material::fresnel::diffuse_reflectance`.
float diffuse_reflectance(float eta) {
    if (eta >= 1.0) {
        return -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
    }
    return -0.4399 + 0.7099 / eta - 0.3319 / (eta * eta) + 0.0636 / (eta * eta * eta);
}

// F_dr,ext = 1 - eta^2 (1 - F_dr): diffuse light from outside reflected by the boundary (reciprocity).
float external_diffuse_reflectance(float eta) {
    return 1.0 - eta * eta * (1.0 - diffuse_reflectance(eta));
}

// Irradiance E(n) from order-2 real spherical harmonics of radiance (Ramamoorthi and Hanrahan
// 2001, Eq. 13), coefficients ordered (0,0), (1,-1), (1,0), (1,1), (2,-2), (2,-1), (2,0), (2,1),
// (2,2); clamped at 0 like `solver::Environment::irradiance` (a truncated expansion can dip below).
vec3 sh_irradiance(vec3 c[9], vec3 n) {
    const float C1 = 0.429043;
    const float C2 = 0.511664;
    const float C3 = 0.743125;
    const float C4 = 0.886227;
    const float C5 = 0.247708;
    vec3 e = C1 * c[8] * (n.x * n.x - n.y * n.y) + C3 * c[6] * n.z * n.z + C4 * c[0] - C5 * c[6]
        + 2.0 * C1 * (c[4] * n.x * n.y + c[7] * n.x * n.z + c[5] * n.y * n.z)
        + 2.0 * C2 * (c[3] * n.x + c[1] * n.y + c[2] * n.z);
    return max(e, vec3(0.0));
}

#endif
