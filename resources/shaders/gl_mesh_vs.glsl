#version 330
// The UV rasterizer: texture coordinates and camera-space depth per pixel.
#define POSED_DEPTH
#include "posed_mesh_include.glsl"
