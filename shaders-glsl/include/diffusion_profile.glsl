// The voxel method's diffusion model (solver::voxel, VoxelModel::Diffusion): DESIGN section 2's
// closed forms along a path. Constants per channel: D = 1 / (3 sigma_t'), s = sigma_tr =
// sqrt(3 sigma_a sigma_t'), h = 2 A D.
#ifndef DIFFUSION_PROFILE_GLSL
#define DIFFUSION_PROFILE_GLSL

// P(d) (1 - F_dr): the transmittance of a slab of thickness d lit uniformly on one face,
// T = 8 D s exp(-s d) / ((1 - F_dr) [(1 + h s)^2 - (1 - h s)^2 exp(-2 s d)]), without its
// exp(-s d) (carried by the path's optical depth) and its 1 / (1 - F_dr). For s d << 1 it falls
// as 4 D / (2 h + d): the 1/d spreading; for s d >> 1 it is a constant.
float slab_profile(float diffusion, float s, float h, float d) {
    float hs = h * s;
    float sd = s * d;
    if (sd < 1e-3) {
        // The series avoids 0 / 0 at s = 0 (no absorption).
        return 8.0 * diffusion / (4.0 * h + 2.0 * d * (1.0 - hs) * (1.0 - hs));
    }
    return 8.0 * diffusion * s / ((1.0 + hs) * (1.0 + hs) - (1.0 - hs) * (1.0 - hs) * exp(-2.0 * sd));
}

// DESIGN section 2's albedo R of a semi-infinite medium under uniform light (h s = 2 A D sigma_tr).
float semi_infinite_albedo(float hs, float f_dr) {
    return max((2.0 / (1.0 + hs) - (1.0 - f_dr)) / (1.0 + f_dr), 0.0);
}

// The exit gain G(d) of a path of length d (mm): M = q exp(-n) G(d). Where the light entered
// (d = 0) a uniformly lit flat face returns R q; far from it the slab profile P(d) (the far face of
// a lit slab as thick as the path is long, with its 1/d spreading); between them the difference
// R - P(0) fades over the profile's own length, 4 A D (P(d) ~ P(0) / (1 + d / (4 A D))):
//   G(d) = P(d) + (R - P(0)) exp(-d / (4 A D)) - B(d),   P(0) = 1 / (1 + F_dr).
// (Before: min(R, P(d)). P(0) is the same in every channel and below R in weakly absorbing media,
// so every lit voxel took it: the lit surface lost its albedo's colour, grey next to the warm
// transmitted light, the purple cast of issue 14, and 0.81 R too dark on marble.)
// B(d): the unscattered part of the slab's transmittance, exp(-sigma_t' d) = exp(-s d)
// exp((s - sigma_t') d), faded in like P(d) - P(0). The diffusion slab's T(d) tends to 1 - R as d
// goes to 0 because it counts the light that crosses a thin slab without scattering; a path
// through the voxels is not a beam through a slab (a path between two lit voxels runs along the
// surface), and the ballistic light of a back-lit wall leaves along the light, not towards the
// eye. Without B a strongly absorbing channel (ketchup's green and blue: R = 0 at eta 1, the
// objective's best path a neighbour 0.3-1 mm away at G ~ 1 - exp(-d / 4AD)) was 10x and 33x the
// path-traced exitance. `big_a` = A = (1 + F_dr) / (1 - F_dr); sigma_t' = 1 / (3 D).
float exit_gain(float diffusion, float s, float big_a, float d) {
    float f_dr = (big_a - 1.0) / (big_a + 1.0);
    float h = 2.0 * big_a * diffusion;
    float inv = 1.0 / (1.0 - f_dr);
    float p_d = slab_profile(diffusion, s, h, d) * inv;
    float p_0 = 1.0 / (1.0 + f_dr);
    float r = semi_infinite_albedo(h * s, f_dr);
    float fade = exp(-d / (2.0 * h));
    float sigma_t = 1.0 / (3.0 * diffusion);
    // exp(80) keeps B finite where s > sigma_t' (albedo below 2/3: B wins, G = 0 off the entry).
    float ballistic = exp(min((s - sigma_t) * d, 80.0));
    return max(p_d + (r - p_0) * fade - ballistic * (1.0 - fade), 0.0);
}

#endif
