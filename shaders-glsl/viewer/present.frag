#version 460
// The viewer's present pass (tools/src/view/present.rs): the HDR image the object was recorded
// into -> exposure, the ACES fit and sRGB (as the PNG writer, engine/src/vk/capture.rs) -> the
// swapchain image, with a backdrop where nothing was drawn and the text overlay on top.
// Not used by the library.

layout(set = 0, binding = 0) uniform sampler2D hdr;
// Glyph rows of ASCII 0..128, 8 bytes per glyph, four per word (tools/src/view/overlay.rs).
layout(std430, set = 0, binding = 1) readonly buffer Font { uint rows[]; } font;
// One cell per word: ascii | colour << 8 | panel << 16, row-major from the top left.
layout(std430, set = 0, binding = 2) readonly buffer Text { uint cells[]; } text;

layout(push_constant) uniform PresentPush {
    ivec2 size;         // the swapchain extent (the HDR image's too)
    ivec2 grid;         // text columns and rows
    float exposure;
    uint encode_srgb;   // 1: the swapchain format is UNORM, encode here; 0: an _SRGB format
    uint text_scale;    // screen pixels per font pixel
    uint overlay;       // 0: no text
} pc;

layout(location = 0) out vec4 out_color;

// Narkowicz's ACES fit, as capture.rs's tone_map.
vec3 tone_map(vec3 x) {
    x = clamp(x, vec3(0.0), vec3(1e6));
    return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}

vec3 srgb(vec3 c) {
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

// Text cell size in font pixels and the margin in screen pixels per text scale
// (tools/src/view/mod.rs's text_grid matches).
const ivec2 CELL = ivec2(8, 10);
const int TEXT_MARGIN = 4;

const vec3 PALETTE[5] = vec3[5](
    vec3(0.92), vec3(0.55), vec3(1.0, 0.85, 0.35), vec3(1.0, 0.35, 0.3), vec3(0.45, 0.95, 0.5));

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 radiance = texelFetch(hdr, p, 0);
    vec3 c;
    if (radiance.a > 0.0) {
        vec3 v = radiance.rgb;
        // NaN never reaches the screen (the PNG writer maps it to 0 too).
        v = mix(v, vec3(0.0), isnan(v));
        c = tone_map(v * pc.exposure);
    } else {
        // Backdrop (display only: screenshots keep the HDR image's black background).
        float t = float(p.y) / float(max(pc.size.y, 1));
        c = mix(vec3(0.035, 0.04, 0.05), vec3(0.012), t);
    }
    if (pc.overlay != 0u) {
        // Cells of 8x10 font pixels (the 8x8 glyph and two rows of line spacing), from a margin.
        ivec2 font_px = (p - ivec2(TEXT_MARGIN * int(pc.text_scale))) / int(pc.text_scale);
        ivec2 cell = font_px / CELL;
        if (all(greaterThanEqual(font_px, ivec2(0))) && all(lessThan(cell, pc.grid))) {
            uint word = text.cells[cell.y * pc.grid.x + cell.x];
            if ((word & 0x10000u) != 0u) {
                c *= 0.3;  // a dark panel behind each line
                uint code = word & 0x7fu;
                ivec2 in_cell = font_px % CELL;
                if (in_cell.y < 8) {
                    uint row_index = code * 8u + uint(in_cell.y);
                    uint row = (font.rows[row_index / 4u] >> (8u * (row_index % 4u))) & 0xffu;
                    if (((row >> uint(in_cell.x)) & 1u) != 0u) {
                        c = PALETTE[min((word >> 8) & 0xffu, 4u)];
                    }
                }
            }
        }
    }
    out_color = vec4(pc.encode_srgb != 0u ? srgb(c) : c, 1.0);
}
