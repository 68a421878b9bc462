#version 460
// The viewer's present pass (tools/src/view/present.rs): one triangle that covers the screen.
// Not used by the library.

void main() {
    vec2 p = vec2((gl_VertexIndex << 1) & 2, gl_VertexIndex & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
