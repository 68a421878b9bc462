#version 460
#extension GL_GOOGLE_include_directive : require
#define HOMOGENEOUS
#include "correction_sweep.glsl"
