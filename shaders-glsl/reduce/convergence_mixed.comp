#version 460
#extension GL_GOOGLE_include_directive : require
#define DELTA_FORMAT rgba16f
#define PHI_FORMAT rgba32f
// fp32 phi (the fp16 correction is recomputed from the fp32 residual): 2^-24.
#define STALL_BELOW 6.0e-8
#include "convergence.glsl"
