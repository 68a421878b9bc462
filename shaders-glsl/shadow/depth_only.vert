#version 460
// Depth-only pass: the mesh seen from a light (tomorrow's shadow map). No fragment shader.
layout(location = 0) in vec3 position;

layout(push_constant) uniform DepthPush {
    mat4 light_view_proj;
} pc;

void main() {
    gl_Position = pc.light_view_proj * vec4(position, 1.0);
}
