#pragma once
// Records the copy of the renderer's two eye images into the acquired swapchain images:
// byte for byte (vkCmdCopyImage between 32-bit RGBA formats), leaving each swapchain
// image in COLOR_ATTACHMENT_OPTIMAL as OpenXR expects on release; and the depth layer's.
#include <volk.h>

#include "gauss/engine/result.h"
#include "gauss/render/depth_projection.h"
#include "gauss/render/splat_renderer.h"
#include "gauss/xr/xr_session.h"

namespace gauss::xr_app {

// With a depth layer (target.depth_images set) each eye's depth goes through `depth` too:
// the renderer's linear mesh depth as the layer's projected depth (far plane without a mesh).
Status record_eye_copy(VkCommandBuffer cmd, render::SplatRenderer& renderer, const xr::FrameTarget& target,
                       render::DepthProjection* depth);

}  // namespace gauss::xr_app
