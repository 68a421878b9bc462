#version 460
// Shadow maps: the mesh's depth seen from one shadow view (a tile of the atlas). No fragment stage.
layout(location = 0) in vec3 position;

layout(push_constant) uniform ShadowPush {
    mat4 view_proj;
} pc;

void main() {
    gl_Position = pc.view_proj * vec4(position, 1.0);
}
