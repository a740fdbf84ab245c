#version 330
// The textured renderer: texture coordinates and the camera-space normal for its shading.
#define POSED_NORMAL
#include "posed_mesh_include.glsl"
