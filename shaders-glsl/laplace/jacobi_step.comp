#version 460
// One Jacobi sweep of the 2D Laplace equation with Dirichlet boundary: interior texels take the
// mean of their 4 neighbours, boundary texels keep their value. Reads `src`, writes `dst`.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, rgba16f) uniform readonly image2D src;
layout(set = 0, binding = 1, rgba16f) uniform writeonly image2D dst;

layout(push_constant) uniform JacobiPush {
    ivec2 size;
} pc;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    vec4 v = imageLoad(src, p);
    bool interior = p.x > 0 && p.y > 0 && p.x < pc.size.x - 1 && p.y < pc.size.y - 1;
    if (interior) {
        v = 0.25 * (imageLoad(src, p + ivec2(1, 0)) + imageLoad(src, p - ivec2(1, 0))
                  + imageLoad(src, p + ivec2(0, 1)) + imageLoad(src, p - ivec2(0, 1)));
    }
    imageStore(dst, p, v);
}
