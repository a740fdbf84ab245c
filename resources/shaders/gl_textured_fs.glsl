#version 330
uniform sampler2D tex;
uniform float shading;
uniform vec3 light_cam;
in vec2 v_uv;
in vec3 v_normal_cam;
layout(location = 0) out vec4 out_rgba;
void main() {
    // Texture rows are stored top first while v points up: sample at t = 1 - v.
    vec3 albedo = texture(tex, vec2(v_uv.x, 1.0 - v_uv.y)).rgb;
    float lambert = max(dot(normalize(v_normal_cam), light_cam), 0.0);
    float light = mix(1.0, 0.35 + 0.75 * lambert, shading);
    out_rgba = vec4(clamp(albedo * light, 0.0, 1.0), 1.0);
}
