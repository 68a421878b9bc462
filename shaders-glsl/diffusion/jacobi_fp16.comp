#version 460
#extension GL_GOOGLE_include_directive : require
// Plain fp16 ping-pong state, the paper's (benchmark mode Precision::Fp16).
#define STATE_FORMAT rgba16f
#include "jacobi_step.glsl"
