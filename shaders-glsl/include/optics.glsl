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

#endif
