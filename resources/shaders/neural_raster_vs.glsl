#version 330 core
// Linear blend skinning of the render mesh (top-8 bones per vertex) followed by the pinhole
// camera; the same maths as morf.body.lbs.linear_blend_skinning. NUM_BONES is set by the loader.
uniform mat4 u_bones[NUM_BONES];   // skinning matrices T_c (rest -> posed), column-major
uniform mat4 u_view_proj;          // gl_projection @ view matrix (framebuffer row 0 = image row 0)

in vec3 in_position;               // shaped rest vertex
in vec2 in_uv;                     // texture coordinate, v up
in ivec4 in_bones0;
in ivec4 in_bones1;
in vec4 in_weights0;
in vec4 in_weights1;

out vec2 v_texcoord;

void main() {
    mat4 skin = in_weights0.x * u_bones[in_bones0.x] + in_weights0.y * u_bones[in_bones0.y]
              + in_weights0.z * u_bones[in_bones0.z] + in_weights0.w * u_bones[in_bones0.w]
              + in_weights1.x * u_bones[in_bones1.x] + in_weights1.y * u_bones[in_bones1.y]
              + in_weights1.z * u_bones[in_bones1.z] + in_weights1.w * u_bones[in_bones1.w];
    vec4 world = skin * vec4(in_position, 1.0);
    // Texture rows are stored top first (row = (1 - v) * H), GL's t axis starts at row 0.
    v_texcoord = vec2(in_uv.x, 1.0 - in_uv.y);
    gl_Position = u_view_proj * vec4(world.xyz, 1.0);
}
