#version 460
// Solid voxelization, step 1 of 3 per axis (solver::voxel::VoxelizePass): every triangle adds its
// signed crossing to the voxel columns along `axis` whose centre line it covers. Column (i, j)'s
// centre line meets the triangle at w_hit; the crossing goes to the first voxel whose centre lies
// beyond w_hit, +1 where the triangle faces -axis (the column enters the solid), -1 where it faces
// +axis (it leaves). A prefix sum along the column (count_votes.comp) then gives each voxel the
// winding number of a ray from -infinity along the axis: 1 inside an outward mesh, -1 inside an
// inverted one, 0 outside (Eisemann and Decoret 2008's parity, with signs).
// Watertight: a shared edge's edge function is evaluated with its two vertices in a canonical
// order, so both triangles get bit-identical values, and a column exactly on an edge goes to
// exactly one of them by a top-left rule (folds at silhouettes: to both or neither, which cancels).
#include "voxel_grid.glsl"

layout(local_size_x = 64) in;

layout(set = 0, binding = 0, std430) readonly buffer Vertices { float values[]; } vertices;
layout(set = 0, binding = 1, std430) readonly buffer Indices { uint values[]; } indices;
layout(set = 0, binding = 2, std430) readonly buffer Grid { GridFrame grid; } grid;
layout(set = 0, binding = 3, std430) buffer Crossings { int counts[]; } crossings;

layout(push_constant) uniform CrossingPush {
    uint triangle_count;
    uint stride;  // floats per vertex
    uint axis;    // 0: x, 1: y, 2: z (the column direction)
    uint pad;
} pc;

// Twice the signed area of (a, b, c), evaluated with a and b in lexicographic order and the sign
// put back, so the two triangles sharing edge ab compute the same magnitude bit for bit.
float edge(vec2 a, vec2 b, vec2 c) {
    bool swap = a.x > b.x || (a.x == b.x && a.y > b.y);
    vec2 s = swap ? b : a;
    vec2 e = swap ? a : b;
    precise float value = (e.x - s.x) * (c.y - s.y) - (e.y - s.y) * (c.x - s.x);
    return swap ? -value : value;
}

// Top-left rule on the counter-clockwise-normalized edge direction d: exactly one of d and -d
// owns the points on the edge.
bool owns_edge(vec2 d) {
    return d.y < 0.0 || (d.y == 0.0 && d.x > 0.0);
}

vec3 position(uint v) {
    uint b = v * pc.stride;
    return vec3(vertices.values[b], vertices.values[b + 1u], vertices.values[b + 2u]);
}

void main() {
    uint t = gl_GlobalInvocationID.x;
    if (t >= pc.triangle_count) {
        return;
    }
    GridFrame g = grid.grid;
    float h = g.origin.w;
    uvec3 dims = g.dims.xyz;
    uint a = pc.axis;
    uint u = (a + 1u) % 3u;
    uint v = (a + 2u) % 3u;
    vec3 p[3] = vec3[3](position(indices.values[3u * t]), position(indices.values[3u * t + 1u]),
                        position(indices.values[3u * t + 2u]));
    vec2 q[3];
    float w[3];
    for (int k = 0; k < 3; ++k) {
        if (any(isnan(p[k])) || any(isinf(p[k]))) {
            return;
        }
        q[k] = vec2(p[k][u], p[k][v]);
        w[k] = p[k][a];
    }
    float orientation = edge(q[0], q[1], q[2]);
    if (orientation == 0.0) {
        return; // edge-on to the columns: its neighbours carry the crossing
    }
    float sigma = orientation > 0.0 ? 1.0 : -1.0;
    // The triangle's normal along the axis has the sign of its projected area (u, v cyclic after a).
    int contribution = sigma > 0.0 ? -1 : 1;
    vec2 lo = min(min(q[0], q[1]), q[2]);
    vec2 hi = max(max(q[0], q[1]), q[2]);
    vec2 origin = vec2(g.origin[u], g.origin[v]);
    ivec2 first = max(ivec2(ceil((lo - origin) / h - 0.5)), ivec2(0));
    ivec2 last = min(ivec2(floor((hi - origin) / h - 0.5)), ivec2(int(dims[u]) - 1, int(dims[v]) - 1));
    // Owned edges of the normalized triangle: edge k runs from vertex k+1 to k+2.
    bool owns[3];
    for (int k = 0; k < 3; ++k) {
        owns[k] = owns_edge(sigma * (q[(k + 2) % 3] - q[(k + 1) % 3]));
    }
    for (int j = first.y; j <= last.y; ++j) {
        for (int i = first.x; i <= last.x; ++i) {
            vec2 c = origin + (vec2(i, j) + 0.5) * h;
            float e[3];
            bool inside = true;
            for (int k = 0; k < 3; ++k) {
                e[k] = sigma * edge(q[(k + 1) % 3], q[(k + 2) % 3], c);
                inside = inside && (e[k] > 0.0 || (e[k] == 0.0 && owns[k]));
            }
            float sum = e[0] + e[1] + e[2];
            if (!inside || !(sum > 0.0)) {
                continue;
            }
            float w_hit = (e[0] * w[0] + e[1] * w[1] + e[2] * w[2]) / sum;
            int k = int(floor((w_hit - g.origin[a]) / h + 0.5));
            if (k >= int(dims[a])) {
                continue;
            }
            ivec3 voxel;
            voxel[a] = max(k, 0);
            voxel[u] = i;
            voxel[v] = j;
            atomicAdd(crossings.counts[voxel_index(voxel, dims)], contribution);
        }
    }
}
