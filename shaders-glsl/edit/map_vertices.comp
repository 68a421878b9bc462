#version 460
// Deformation, step 1 (paper section 6.4; DESIGN section 4): the rest-pose tetrahedron vertices of
// one level through an analytic map, on the GPU. mode 0: affine (column-major 4x4, w = 1);
// mode 1: twist about +Y through the origin, rate * y radians at height y (R_y: x' = c x + s z,
// z' = -s x + c z). Uploaded vertex positions (Deformation::TetPositions) skip this pass.
layout(local_size_x = 64) in;

layout(set = 0, binding = 0, std430) readonly buffer RestVertices { vec4 data[]; } rest;
layout(set = 0, binding = 1, std430) writeonly buffer Vertices { vec4 data[]; } vertices;

layout(push_constant) uniform MapPush {
    mat4 affine;
    uint count;
    uint mode;
    float rate;
    uint pad;
} pc;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= pc.count) {
        return;
    }
    vec3 p = rest.data[i].xyz;
    vec3 q;
    if (pc.mode == 0u) {
        q = (pc.affine * vec4(p, 1.0)).xyz;
    } else {
        float a = pc.rate * p.y;
        float c = cos(a);
        float s = sin(a);
        q = vec3(c * p.x + s * p.z, p.y, -s * p.x + c * p.z);
    }
    vertices.data[i] = vec4(q, 1.0);
}
