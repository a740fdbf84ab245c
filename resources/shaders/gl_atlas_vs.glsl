#version 330
in vec2 in_uv;
in vec4 in_attr;
out vec4 v_attr;
void main() {
    v_attr = in_attr;
    // texture row 0 is v = 1, and read-back row 0 is NDC y = -1: put v = 1 at y = -1
    gl_Position = vec4(2.0 * in_uv.x - 1.0, 1.0 - 2.0 * in_uv.y, 0.0, 1.0);
}
