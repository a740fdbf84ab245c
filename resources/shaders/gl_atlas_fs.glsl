#version 330
in vec4 v_attr;
layout(location = 0) out vec4 out_attr;
layout(location = 1) out vec4 out_cover;
void main() {
    out_attr = v_attr;
    out_cover = vec4(1.0);
}
