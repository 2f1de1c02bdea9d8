#version 460
// Mesh pass vertex shader: OpenCV pinhole projection straight to Vulkan clip space
// (x right, y down, both match the framebuffer), so a pixel centre (j + 0.5, i + 0.5)
// samples exactly where splat_math.h says. The view depth t.z goes to the fragment
// shader, which writes it (scaled) as the depth value.
#extension GL_GOOGLE_include_directive : require

#include "splat_layout.h"

layout(location = 0) in vec3 in_position;
layout(location = 1) in vec4 in_colour;
layout(location = 0) out vec4 out_colour;
layout(location = 1) out float out_view_depth;
layout(push_constant) uniform Push { GpuMeshPush pc; };

void main() {
  const vec4 p = vec4(in_position, 1.0);
  const vec3 t = vec3(dot(pc.w2c_row0, p), dot(pc.w2c_row1, p), dot(pc.w2c_row2, p));
  const float near = pc.viewport.z, far = pc.viewport.w;
  // u = fx x / z + cx -> x_ndc = 2 u / width - 1; multiplied through by w = t.z.
  const float x_clip = (2.0 * (pc.intrinsics.x * t.x + pc.intrinsics.z * t.z)) / pc.viewport.x - t.z;
  const float y_clip = (2.0 * (pc.intrinsics.y * t.y + pc.intrinsics.w * t.z)) / pc.viewport.y - t.z;
  // Depth only clips here (near..far maps to 0..w); the fragment shader writes the depth.
  const float z_clip = (t.z - near) * far / (far - near);
  gl_Position = vec4(x_clip, y_clip, z_clip, t.z);
  out_colour = in_colour;
  out_view_depth = t.z;
}
