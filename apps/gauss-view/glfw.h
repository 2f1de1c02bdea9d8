#pragma once
// GLFW with its Vulkan functions: GLFW declares glfwCreateWindowSurface and friends only when
// a Vulkan header came first, and its include guard then fixes that for the rest of the
// translation unit (in a unity batch, for every file after the first that includes it).
// So every file of the viewer includes GLFW through here.
#include <volk.h>

#include <GLFW/glfw3.h>
