#version 330
uniform mat4 view;
uniform mat4 proj;
in vec3 in_pos;
in vec3 in_normal;
in vec2 in_uv;
out vec2 v_uv;
out vec3 v_normal_cam;
void main() {
    vec4 pc = view * vec4(in_pos, 1.0);
    v_uv = in_uv;
    v_normal_cam = mat3(view) * in_normal;
    gl_Position = proj * pc;
}
