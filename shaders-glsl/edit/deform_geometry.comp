#version 460
// Deformation, step 3 (DESIGN section 4: A_f, V_i and d recomputed in fp32 on the GPU): the
// geometric factors of every node from the deformed tetrahedra and node positions, as
// textures.rs::geometric_factors does in f64 at bake time:
//   fv inner:    g_if = A_f / (V_i d_ij), d_ij = |n_f . (x_j - x_i)|, t_if = delta_i / (delta_i + delta_j)
//                (1 towards a surface node);  paper inner: g_if = 1 / |x_j - x_i|^2
//   surface s on face f of cell k: g_s0 = 1 / d_sk (fv: along n_f; paper: Euclidean).
// Degenerate (flattened) cells are clamped, never divided by zero: V >= min_volume,
// d >= min_distance (deform() already refuses inputs that flatten a tetrahedron; the clamp
// catches what fp32 rounding of a nearly flat one would still produce).
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0, std430) readonly buffer Cells { uint data[]; } cells;
layout(set = 0, binding = 1, std430) readonly buffer Tets { uvec4 data[]; } tets;
layout(set = 0, binding = 2, std430) readonly buffer Vertices { vec4 data[]; } vertices;
layout(set = 0, binding = 3, std430) readonly buffer NodePositions { vec4 data[]; } node_pos;
layout(set = 0, binding = 4, rgba32ui) uniform readonly uimage2D connectivity;
layout(set = 0, binding = 5, rgba32f) uniform writeonly image2D geo;
layout(set = 0, binding = 6, rgba32f) uniform writeonly image2D frac;

layout(push_constant) uniform GeometryPush {
    ivec2 size;
    uint width;
    uint surface_rows;
    uint paper;
    float min_volume;
    float min_distance;
    uint pad;
} pc;

const uint NO_CELL = 0xffffffffu;
// Local vertex indices of face f (quadgraph::graph::TET_FACES), outward for positive tetrahedra.
const uvec3 FACES[4] = uvec3[4](uvec3(1, 2, 3), uvec3(0, 3, 2), uvec3(0, 1, 3), uvec3(0, 2, 1));

vec3 vertex_of(uvec4 tet, uint l) {
    return vertices.data[tet[l]].xyz;
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (p.x >= pc.size.x || p.y >= pc.size.y) {
        return;
    }
    uint t = uint(p.y) * pc.width + uint(p.x);
    uint cell = cells.data[t];
    vec4 g = vec4(0.0);
    vec4 fr = vec4(0.0);
    if (cell != NO_CELL) {
        bool surface = uint(p.y) < pc.surface_rows;
        uvec4 nb = imageLoad(connectivity, p);
        vec3 xi = node_pos.data[t].xyz;
        if (surface) {
            uvec4 tet = tets.data[cell >> 2];
            uvec3 f = FACES[cell & 3u];
            vec3 p0 = vertex_of(tet, f.x);
            vec3 n = normalize(cross(vertex_of(tet, f.y) - p0, vertex_of(tet, f.z) - p0));
            vec3 xk = node_pos.data[nb.x].xyz;
            float d = pc.paper != 0u ? length(xi - xk) : abs(dot(n, xi - xk));
            g.x = 1.0 / max(d, pc.min_distance);
        } else {
            uvec4 tet = tets.data[cell];
            vec3 v0 = vertex_of(tet, 0u);
            float volume = dot(vertex_of(tet, 1u) - v0,
                               cross(vertex_of(tet, 2u) - v0, vertex_of(tet, 3u) - v0)) / 6.0;
            volume = max(volume, pc.min_volume);
            for (uint k = 0u; k < 4u; ++k) {
                uvec3 f = FACES[k];
                vec3 p0 = vertex_of(tet, f.x);
                vec3 n2 = cross(vertex_of(tet, f.y) - p0, vertex_of(tet, f.z) - p0);
                float len = length(n2);
                float area = 0.5 * len;
                vec3 n = len > 0.0 ? n2 / len : vec3(0.0);
                vec3 xj = node_pos.data[nb[k]].xyz;
                bool j_surface = nb[k] / pc.width < pc.surface_rows;
                if (pc.paper != 0u) {
                    vec3 e = xj - xi;
                    g[k] = 1.0 / max(dot(e, e), pc.min_distance * pc.min_distance);
                } else {
                    float dij = max(abs(dot(n, xj - xi)), pc.min_distance);
                    float di = abs(dot(n, xi - p0));
                    float dj = abs(dot(n, xj - p0));
                    g[k] = area / (volume * dij);
                    fr[k] = j_surface ? 1.0 : di / max(di + dj, pc.min_distance);
                }
            }
        }
    }
    imageStore(geo, p, g);
    imageStore(frac, p, fr);
}
