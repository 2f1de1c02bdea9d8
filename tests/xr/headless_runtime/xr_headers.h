#pragma once
// The one include for the OpenXR and Vulkan types the runtime uses. The target defines
// VK_NO_PROTOTYPES and XR_NO_PROTOTYPES: the runtime calls Vulkan only through the
// application's vkGetInstanceProcAddr (so its calls go through the app's layers and never
// clash with the app's own loader, e.g. volk) and calls no OpenXR loader function at all,
// so no prototype can be called by mistake. XR_USE_GRAPHICS_API_VULKAN is defined there too.
#include <vulkan/vulkan.h>

#include <openxr/openxr.h>
#include <openxr/openxr_platform.h>
