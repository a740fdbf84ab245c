#version 330 core
// Neural rasterization: the 16-channel uint8 neural texture (four RGBA8 textures, bilinear, no
// mipmaps, as torch grid_sample samples it in training) written as 16 bytes per pixel into one
// RGBA32UI attachment: component i holds channels 4i..4i+3, lowest byte first, so the read-back
// is the (H, W, 16) channels-last uint8 image the renderer reads. Bytes are rounded exactly as
// a UNORM8 attachment would store them. The framebuffer is cleared to 0x80 bytes (= the
// texture's zero point, i.e. background value 0). On the body channel 0 is never 0x80 (0x81
// instead, one step): that byte alone tells the renderer graph where the body is
// (morf/raster/neural_raster.py, COVERAGE_CHANNEL). The textures have no mipmaps and filter
// linearly both ways, so sampling at level 0 (textureLod) is the same bilinear sample as texture()
// without its derivatives and level selection (a tenth of the raster's time in SwiftShader).
uniform sampler2D u_texture0;
uniform sampler2D u_texture1;
uniform sampler2D u_texture2;
uniform sampler2D u_texture3;

in vec2 v_texcoord;

layout(location = 0) out uvec4 out_channels;

uvec4 to_bytes(vec4 c) {
    return uvec4(round(clamp(c, 0.0, 1.0) * 255.0));
}

uint pack_bytes(uvec4 b) {
    return b.x | (b.y << 8) | (b.z << 16) | (b.w << 24);
}

void main() {
    uvec4 first = to_bytes(textureLod(u_texture0, v_texcoord, 0.0));
    first.x = first.x == 128u ? 129u : first.x;  // the coverage mark
    out_channels = uvec4(pack_bytes(first), pack_bytes(to_bytes(textureLod(u_texture1, v_texcoord, 0.0))),
                         pack_bytes(to_bytes(textureLod(u_texture2, v_texcoord, 0.0))),
                         pack_bytes(to_bytes(textureLod(u_texture3, v_texcoord, 0.0))));
}
