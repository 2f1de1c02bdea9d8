#version 460
// Test-only vertex shader (tests/render/test_vk_offscreen.cpp): passes an interleaved
// position + colour vertex through unchanged (positions already in clip space).
layout(location = 0) in vec4 in_position;
layout(location = 1) in vec4 in_color;
layout(location = 0) out vec4 out_color;

void main() {
  gl_Position = in_position;
  out_color = in_color;
}
