#version 460
#extension GL_GOOGLE_include_directive : require
#define PHI_FORMAT rgba32f
#include "vertex_interior.glsl"
