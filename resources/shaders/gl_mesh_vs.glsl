#version 330
uniform mat4 view;
uniform mat4 proj;
in vec3 in_pos;
in vec2 in_uv;
out vec2 v_uv;
out float v_depth;
void main() {
    vec4 pc = view * vec4(in_pos, 1.0);
    v_uv = in_uv;
    v_depth = pc.z;
    gl_Position = proj * pc;
}
