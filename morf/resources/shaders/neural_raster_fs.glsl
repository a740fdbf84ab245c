#version 330 core
// Neural rasterization: the 16-channel uint8 neural texture (four RGBA8 textures, bilinear, no
// mipmaps, as torch grid_sample samples it in training) written as 16 bytes per pixel into one
// RGBA32UI attachment: component i holds channels 4i..4i+3, lowest byte first, so the read-back
// is the (H, W, 16) channels-last uint8 image the renderer reads. Bytes are rounded exactly as
// a UNORM8 attachment would store them. The framebuffer is cleared to 0x80 bytes (= the
// texture's zero point, i.e. background value 0).
uniform sampler2D u_texture0;
uniform sampler2D u_texture1;
uniform sampler2D u_texture2;
uniform sampler2D u_texture3;

in vec2 v_texcoord;

layout(location = 0) out uvec4 out_channels;

uint pack_bytes(vec4 c) {
    uvec4 b = uvec4(round(clamp(c, 0.0, 1.0) * 255.0));
    return b.x | (b.y << 8) | (b.z << 16) | (b.w << 24);
}

void main() {
    out_channels = uvec4(pack_bytes(texture(u_texture0, v_texcoord)), pack_bytes(texture(u_texture1, v_texcoord)),
                         pack_bytes(texture(u_texture2, v_texcoord)), pack_bytes(texture(u_texture3, v_texcoord)));
}
