#version 330 core
// Neural rasterization: the 16-channel uint8 neural texture (four RGBA8 textures, bilinear, no
// mipmaps, as torch grid_sample samples it in training) written to four RGBA8 attachments.
// The framebuffer is cleared to 128/255 = the texture's zero point, i.e. background value 0.
uniform sampler2D u_texture0;
uniform sampler2D u_texture1;
uniform sampler2D u_texture2;
uniform sampler2D u_texture3;

in vec2 v_texcoord;

layout(location = 0) out vec4 out_channels0;
layout(location = 1) out vec4 out_channels1;
layout(location = 2) out vec4 out_channels2;
layout(location = 3) out vec4 out_channels3;

void main() {
    out_channels0 = texture(u_texture0, v_texcoord);
    out_channels1 = texture(u_texture1, v_texcoord);
    out_channels2 = texture(u_texture2, v_texcoord);
    out_channels3 = texture(u_texture3, v_texcoord);
}
