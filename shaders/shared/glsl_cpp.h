// One header, two languages: lets a layout header in shaders/shared/ be included both
// by GLSL (glslangValidator -I shaders/shared) and by C++, so GPU struct layouts,
// bindings, workgroup sizes and constants are defined exactly once.
//
// GLSL files need `#extension GL_GOOGLE_include_directive : require` first.
// In a shared header:
//   #include "glsl_cpp.h"
//   GAUSS_SHARED_BEGIN
//   GAUSS_CONST(uint, MY_WORKGROUP_SIZE, 256u)   // C++: gauss::gpu::MY_WORKGROUP_SIZE
//   GAUSS_BINDING(MY_BINDING_SPLATS, 0)           // C++: gauss::gpu::MY_BINDING_SPLATS
//   struct MyGpuStruct { vec4 a; uvec4 b; };       // same bytes on both sides (see rules)
//   GAUSS_SHARED_END
//   GAUSS_STATIC_ASSERT(sizeof(gauss::gpu::MyGpuStruct) == 32, "std430 layout changed");
//
// Layout rules (std430 on the GPU, plain C++ on the CPU): use scalars (uint, int,
// float), vec2/uvec2 at 8-byte offsets and vec4/uvec4/mat4 at 16-byte offsets; never
// vec3 (16-byte aligned in GLSL, 12 bytes in glm); pad explicitly; static_assert sizes
// and, for anything non-trivial, offsetof.
#ifndef GAUSS_SHADERS_SHARED_GLSL_CPP_H
#define GAUSS_SHADERS_SHARED_GLSL_CPP_H

#ifdef __cplusplus

#include <cstdint>

#include <glm/glm.hpp>

namespace gauss::gpu {
using uint = std::uint32_t;
using vec2 = glm::vec2;
using vec4 = glm::vec4;
using ivec2 = glm::ivec2;
using ivec4 = glm::ivec4;
using uvec2 = glm::uvec2;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
static_assert(sizeof(vec4) == 16 && sizeof(uvec4) == 16 && sizeof(mat4) == 64,
              "glm types must match the GLSL std430 sizes");
}  // namespace gauss::gpu

#define GAUSS_SHARED_BEGIN namespace gauss::gpu {
#define GAUSS_SHARED_END }
#define GAUSS_CONST(type, name, value) inline constexpr type name = (value);
#define GAUSS_BINDING(name, index) inline constexpr ::std::uint32_t name = (index);
#define GAUSS_STATIC_ASSERT(cond, msg) static_assert(cond, msg)

#else  // GLSL

#define GAUSS_SHARED_BEGIN
#define GAUSS_SHARED_END
#define GAUSS_CONST(type, name, value) const type name = (value);
// A const uint: GLSL accepts it inside layout(binding = NAME).
#define GAUSS_BINDING(name, index) const uint name = (index);
#define GAUSS_STATIC_ASSERT(cond, msg)

#endif

#endif  // GAUSS_SHADERS_SHARED_GLSL_CPP_H
