#version 330
uniform mat4 view;
uniform mat4 proj;
in vec3 in_pos;
void main() { gl_Position = proj * view * vec4(in_pos, 1.0); }
