#version 460
#extension GL_GOOGLE_include_directive : require
// Plain fp32 ping-pong state (benchmark mode Precision::Fp32).
#define STATE_FORMAT rgba32f
#include "jacobi_step.glsl"
