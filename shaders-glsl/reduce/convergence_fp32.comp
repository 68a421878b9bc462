#version 460
#extension GL_GOOGLE_include_directive : require
#define DELTA_FORMAT rgba32f
#define PHI_FORMAT rgba32f
// fp32 phi: half an ulp, 2^-24, relative.
#define STALL_BELOW 6.0e-8
#include "convergence.glsl"
