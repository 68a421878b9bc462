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

#endif
