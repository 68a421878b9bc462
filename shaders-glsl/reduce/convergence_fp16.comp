#version 460
#extension GL_GOOGLE_include_directive : require
#define DELTA_FORMAT rgba16f
#define PHI_FORMAT rgba16f
#include "convergence.glsl"
