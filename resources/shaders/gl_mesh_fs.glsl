#version 330
in vec2 v_uv;
in float v_depth;
layout(location = 0) out vec4 out_attr;
void main() {
    // face id + 1 so that the cleared value 0 means background; exact in float32 below 2^24
    out_attr = vec4(v_uv, v_depth, float(gl_PrimitiveID + 1));
}
