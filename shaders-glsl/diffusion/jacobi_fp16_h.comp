#version 460
#extension GL_GOOGLE_include_directive : require
// Homogeneous material: geometric weights + push-constant kappa, mu (graph_weights.glsl).
#define HOMOGENEOUS
#define STATE_FORMAT rgba16f
#include "jacobi_step.glsl"
