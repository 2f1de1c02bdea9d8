#version 460
// Mesh pass fragment shader: vertex colour, and the view depth t.z (metres) written as
// depth / SPLAT_MESH_DEPTH_SCALE so the depth attachment holds the linear view depth
// exactly (power-of-two scale) and the depth test keeps the nearest surface.
#extension GL_GOOGLE_include_directive : require

#include "splat_layout.h"

layout(location = 0) in vec4 in_colour;
layout(location = 1) in float in_view_depth;
layout(location = 0) out vec4 out_colour;

void main() {
  out_colour = vec4(in_colour.rgb, 1.0);
  gl_FragDepth = clamp(in_view_depth / SPLAT_MESH_DEPTH_SCALE, 0.0, 1.0);
}
