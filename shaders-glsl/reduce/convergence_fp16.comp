#version 460
#extension GL_GOOGLE_include_directive : require
#define DELTA_FORMAT rgba16f
#define PHI_FORMAT rgba16f
// fp16 phi: half an ulp, 2^-11, relative.
#define STALL_BELOW 4.9e-4
#include "convergence.glsl"
