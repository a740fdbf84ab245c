// The body mesh seen through the camera: texture coordinates for the fragment stage and, as the
// including stage defines, the camera-space depth (POSED_DEPTH: the UV rasterizer,
// gl_mesh_vs.glsl) or normal (POSED_NORMAL: the textured renderer, gl_textured_vs.glsl).
// No #version: morf.resources.shader_source puts this text where a stage says #include.
uniform mat4 view;
uniform mat4 proj;
in vec3 in_pos;
in vec2 in_uv;
out vec2 v_uv;
#ifdef POSED_DEPTH
out float v_depth;
#endif
#ifdef POSED_NORMAL
in vec3 in_normal;
out vec3 v_normal_cam;
#endif
void main() {
    vec4 pc = view * vec4(in_pos, 1.0);
    v_uv = in_uv;
#ifdef POSED_DEPTH
    v_depth = pc.z;
#endif
#ifdef POSED_NORMAL
    v_normal_cam = mat3(view) * in_normal;
#endif
    gl_Position = proj * pc;
}
