#version 330 core
// The neural rasterization's vertex stage for vertices skinned on the CPU
// (morf/raster/skinning_kernels.py): only the pinhole camera. neural_raster_vs.glsl skins in
// the shader instead, where numba is missing.
uniform mat4 u_view_proj;          // gl_projection @ view matrix (framebuffer row 0 = image row 0)

in vec3 in_position;               // posed vertex
in vec2 in_uv;                     // texture coordinate, v up

out vec2 v_texcoord;

void main() {
    // Texture rows are stored top first (row = (1 - v) * H), GL's t axis starts at row 0.
    v_texcoord = vec2(in_uv.x, 1.0 - in_uv.y);
    gl_Position = u_view_proj * vec4(in_position, 1.0);
}
