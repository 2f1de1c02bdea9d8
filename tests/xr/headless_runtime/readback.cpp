#include "readback.h"

#include <cstdio>
#include <cstring>
#include <fstream>

#include <nlohmann/json.hpp>

#include "xr_util.h"

namespace gauss::xr_headless {
namespace {

using nlohmann::json;

std::string format_name(VkFormat f) {
  switch (f) {
    case VK_FORMAT_R8G8B8A8_UNORM: return "VK_FORMAT_R8G8B8A8_UNORM";
    case VK_FORMAT_R8G8B8A8_SRGB: return "VK_FORMAT_R8G8B8A8_SRGB";
    case VK_FORMAT_B8G8R8A8_UNORM: return "VK_FORMAT_B8G8R8A8_UNORM";
    case VK_FORMAT_D32_SFLOAT: return "VK_FORMAT_D32_SFLOAT";
    default: return "VkFormat " + std::to_string(static_cast<int>(f));
  }
}

std::string frame_stem(std::uint64_t index) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "frame-%06llu", static_cast<unsigned long long>(index));
  return buf;
}

json pose_json(const XrPosef& p) {
  return {{"position", {p.position.x, p.position.y, p.position.z}},
          {"orientation", {p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z}}};
}

json fov_json(const XrFovf& f) {
  return {{"left", f.angleLeft}, {"right", f.angleRight}, {"up", f.angleUp}, {"down", f.angleDown}};
}

json rect_json(const XrRect2Di& r) { return {r.offset.x, r.offset.y, r.extent.width, r.extent.height}; }

Status write_file(const std::filesystem::path& path, const void* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) return Error{path.string() + ": cannot write"};
  return Ok{};
}

// A host-visible buffer on the app's device, freed with the object.
struct HostBuffer {
  VulkanDevice& vk;
  VkBuffer buffer{VK_NULL_HANDLE};
  VkDeviceMemory memory{VK_NULL_HANDLE};
  bool coherent{false};
  explicit HostBuffer(VulkanDevice& d) : vk(d) {}
  HostBuffer(const HostBuffer&) = delete;
  HostBuffer& operator=(const HostBuffer&) = delete;
  ~HostBuffer() {
    if (buffer != VK_NULL_HANDLE) vk.vkDestroyBuffer(vk.device, buffer, nullptr);
    if (memory != VK_NULL_HANDLE) vk.vkFreeMemory(vk.device, memory, nullptr);
  }

  Status create(VkDeviceSize size) {
    VkBufferCreateInfo bi{};
    bi.sType = VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO;
    bi.size = size;
    bi.usage = VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    bi.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
    VkResult r = vk.vkCreateBuffer(vk.device, &bi, nullptr, &buffer);
    if (r != VK_SUCCESS) return Error{"vkCreateBuffer (readback): " + vk_result_name(r)};
    VkMemoryRequirements req{};
    vk.vkGetBufferMemoryRequirements(vk.device, buffer, &req);
    auto type = vk.memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT);
    coherent = bool(type);
    if (!type) type = vk.memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT);
    if (!type) return Error{"readback: no host-visible memory type"};
    VkMemoryAllocateInfo ai{};
    ai.sType = VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO;
    ai.allocationSize = req.size;
    ai.memoryTypeIndex = *type;
    r = vk.vkAllocateMemory(vk.device, &ai, nullptr, &memory);
    if (r != VK_SUCCESS) return Error{"vkAllocateMemory (readback): " + vk_result_name(r)};
    r = vk.vkBindBufferMemory(vk.device, buffer, memory, 0);
    if (r != VK_SUCCESS) return Error{"vkBindBufferMemory (readback): " + vk_result_name(r)};
    return Ok{};
  }
};

// Records: attachment layout -> TRANSFER_SRC, copy the rect of one array layer (mip 0),
// back to the attachment layout, and make the copy visible to the host. The source scope
// is ALL_COMMANDS / MEMORY_WRITE because the app may have written the image any way it
// likes (render pass, clear, compute) before releasing it.
void record_copy(VulkanDevice& vk, VkCommandBuffer cmd, const CapturedView& view, VkBuffer buffer) {
  const Swapchain& sc = *view.swapchain;
  VkImageMemoryBarrier to_src{};
  to_src.sType = VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER;
  to_src.srcAccessMask = VK_ACCESS_MEMORY_WRITE_BIT;
  to_src.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
  to_src.oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  to_src.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  to_src.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  to_src.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  to_src.image = sc.images[*sc.last_released];
  to_src.subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, view.array_index, 1};
  vk.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr,
                          1, &to_src);
  VkBufferImageCopy region{};
  region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, view.array_index, 1};
  region.imageOffset = {view.rect.offset.x, view.rect.offset.y, 0};
  region.imageExtent = {static_cast<std::uint32_t>(view.rect.extent.width), static_cast<std::uint32_t>(view.rect.extent.height), 1};
  vk.vkCmdCopyImageToBuffer(cmd, to_src.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, buffer, 1, &region);
  VkImageMemoryBarrier back = to_src;
  back.srcAccessMask = 0;  // a read needs no availability; the next use only waits for it
  back.dstAccessMask = VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT;
  back.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  back.newLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  VkBufferMemoryBarrier to_host{};
  to_host.sType = VK_STRUCTURE_TYPE_BUFFER_MEMORY_BARRIER;
  to_host.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
  to_host.dstAccessMask = VK_ACCESS_HOST_READ_BIT;
  to_host.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  to_host.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
  to_host.buffer = buffer;
  to_host.size = VK_WHOLE_SIZE;
  vk.vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT | VK_PIPELINE_STAGE_HOST_BIT,
                          0, 0, nullptr, 1, &to_host, 1, &back);
}

// Reads one view's pixels into `out` as R, G, B, A bytes.
Status read_view(VulkanDevice& vk, const CapturedView& view, std::vector<std::uint8_t>& out) {
  const std::size_t bytes = std::size_t(view.rect.extent.width) * view.rect.extent.height * 4;
  HostBuffer buf(vk);
  if (auto st = buf.create(bytes); !st) return st;
  if (auto st = vk.submit_and_wait([&](VkCommandBuffer cmd) { record_copy(vk, cmd, view, buf.buffer); }, "readback"); !st)
    return st;
  void* mapped = nullptr;
  const VkResult r = vk.vkMapMemory(vk.device, buf.memory, 0, VK_WHOLE_SIZE, 0, &mapped);
  if (r != VK_SUCCESS) return Error{"vkMapMemory (readback): " + vk_result_name(r)};
  if (!buf.coherent) {
    VkMappedMemoryRange range{};
    range.sType = VK_STRUCTURE_TYPE_MAPPED_MEMORY_RANGE;
    range.memory = buf.memory;
    range.size = VK_WHOLE_SIZE;
    vk.vkInvalidateMappedMemoryRanges(vk.device, 1, &range);
  }
  out.resize(bytes);
  std::memcpy(out.data(), mapped, bytes);
  vk.vkUnmapMemory(vk.device, buf.memory);
  if (view.swapchain->format == VK_FORMAT_B8G8R8A8_UNORM)
    for (std::size_t i = 0; i < bytes; i += 4) std::swap(out[i], out[i + 2]);
  return Ok{};
}

}  // namespace

Status capture_frame(VulkanDevice& vk, const std::filesystem::path& dir, const CapturedFrame& frame) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error{dir.string() + ": cannot create the capture folder (" + ec.message() + ")"};
  // The app submitted its work for these images before releasing them; our copy is queued
  // after it and its barrier waits for it anyway. Waiting for the queue first keeps a
  // fault in the app's work from looking like a failure of the copy.
  if (const VkResult r = vk.vkQueueWaitIdle(vk.queue); r != VK_SUCCESS)
    return Error{"vkQueueWaitIdle before the readback: " + vk_result_name(r)};
  const std::string stem = frame_stem(frame.index);
  json doc;
  doc["frame"] = frame.index;
  doc["predicted_display_time"] = frame.predicted_display_time;
  doc["display_time"] = frame.display_time;
  doc["space"] = frame.space;
  doc["layer_flags"] = frame.layer_flags;
  doc["width"] = frame.views[0].rect.extent.width;
  doc["height"] = frame.views[0].rect.extent.height;
  doc["format"] = format_name(frame.views[0].swapchain->format);
  json views = json::array();
  for (std::size_t eye = 0; eye < frame.views.size(); ++eye) {
    const CapturedView& v = frame.views[eye];
    const std::string file = stem + "-eye" + std::to_string(eye) + ".rgba";
    std::vector<std::uint8_t> pixels;
    if (auto st = read_view(vk, v, pixels); !st) return st;
    if (auto st = write_file(dir / file, pixels.data(), pixels.size()); !st) return st;
    json jv = {{"file", file},
               {"width", v.rect.extent.width},
               {"height", v.rect.extent.height},
               {"format", format_name(v.swapchain->format)},
               {"rect", rect_json(v.rect)},
               {"array_index", v.array_index},
               {"pose", pose_json(v.pose)},
               {"fov", fov_json(v.fov)}};
    if (v.depth) {
      jv["depth"] = {{"rect", rect_json(v.depth->rect)}, {"array_index", v.depth->array_index},
                     {"format", format_name(v.depth->swapchain->format)}, {"min_depth", v.depth->min_depth},
                     {"max_depth", v.depth->max_depth}, {"near_z", v.depth->near_z}, {"far_z", v.depth->far_z}};
    }
    views.push_back(std::move(jv));
  }
  doc["views"] = std::move(views);
  const std::string text = doc.dump(2) + "\n";
  return write_file(dir / (stem + ".json"), text.data(), text.size());
}

Status write_session_summary(const Session& session, const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return Error{dir.string() + ": cannot create the capture folder (" + ec.message() + ")"};
  json states = json::array();
  for (XrSessionState s : session.state_history) states.push_back(session_state_name(s));
  const json doc = {{"states", states},
                    {"frame_count", session.frames_begun},
                    {"frames_submitted", session.frames_ended},
                    {"captured_frames", session.captured_frames},
                    {"quad_frames", session.quad_frames}};
  const std::string text = doc.dump(2) + "\n";
  return write_file(dir / "session.json", text.data(), text.size());
}

}  // namespace gauss::xr_headless
