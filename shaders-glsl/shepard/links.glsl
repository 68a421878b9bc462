// The packed Shepard links of a level (solver/gpu/textures.rs, `pack_link`): 8 links per texel in
// two RGBA32UI, each u32 = coarse linear texel index << 8 | weight in 1/255 (0: no link). 32 bytes
// per texel instead of 48 (u32 indices + fp16 weights); the weights are an initial guess's
// (renormalized by the reader), so 8 bits are enough: the iterations converge from it.
#ifndef LINKS_GLSL
#define LINKS_GLSL

uint link_texel(uint link) {
    return link >> 8;
}

float link_weight(uint link) {
    return float(link & 255u) * (1.0 / 255.0);
}

#endif
