#pragma once
// Records the copy of the renderer's two eye images into the acquired swapchain images:
// byte for byte (vkCmdCopyImage between 32-bit RGBA formats), leaving each swapchain
// image in COLOR_ATTACHMENT_OPTIMAL as OpenXR expects on release.
#include <volk.h>

#include "gauss/engine/result.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/xr/xr_session.h"

namespace gauss::xr_app {

Status record_eye_copy(VkCommandBuffer cmd, render::SplatRenderer& renderer, const xr::FrameTarget& target);

}  // namespace gauss::xr_app
