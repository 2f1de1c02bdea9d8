// MeshPass: the surface mesh as the splats' background colour and per-pixel depth cut.
#include "gauss/render/mesh_pass.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "gauss/render/splat_math.h"
#include "gauss/render/vk_context.h"
#include "gauss/render/vk_frame_ring.h"
#include "gauss/render/vk_staged_uploads.h"
#include "gauss/shaders/mesh.frag.spv.h"
#include "gauss/shaders/mesh.vert.spv.h"
#include "splat_layout.h"

namespace gauss::render {

Expected<MeshPass> MeshPass::create(vk::Context& context) {
  MeshPass pass;
  auto pipe = vk::GraphicsPipeline::create(
      context, {.name = "mesh pass",
                .vertex_shader = vk::spirv(gauss_spv_mesh_vert),
                .fragment_shader = vk::spirv(gauss_spv_mesh_frag),
                .vertex_stride = sizeof(MeshVertex),
                .attributes = {{0, VK_FORMAT_R32G32B32_SFLOAT, 0}, {1, VK_FORMAT_R8G8B8A8_UNORM, 12}},
                .depth_test = true,
                .depth_write = true,
                .depth_compare = VK_COMPARE_OP_LESS,
                .push_constant_size = sizeof(gpu::GpuMeshPush)});
  if (!pipe) return Error{"MeshPass: " + pipe.message()};
  pass.pipeline_ = std::move(*pipe);
  return pass;
}

Status MeshPass::set_mesh(vk::Context& context, const TriangleMesh& mesh, const MeshUpdate& via) {
  if (mesh.positions.empty() || mesh.indices.empty()) return Error{"MeshPass::set_mesh: the mesh is empty"};
  std::map<std::uint64_t, Chunk> old;
  old.swap(chunks_);
  if (auto st = set_chunk(context, 0, mesh, via); !st) {
    chunks_.swap(old);
    return st;
  }
  for (auto& [id, chunk] : old) retire(std::move(chunk), via);
  return Ok{};
}

Expected<PreparedMeshChunk> prepare_mesh_chunk(std::uint64_t id, const TriangleMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  const std::string where = "MeshPass::set_chunk: chunk " + std::to_string(id) + ": ";
  if (nv == 0 || mesh.indices.empty()) return Error{"MeshPass::set_chunk: the mesh is empty"};
  if (mesh.colors.size() != nv)
    return Error{where + std::to_string(mesh.colors.size()) + " colours for " + std::to_string(nv) + " positions"};
  if (mesh.indices.size() % 3 != 0)
    return Error{where + "index count " + std::to_string(mesh.indices.size()) + " is not a multiple of 3"};
  if (mesh.indices.size() > std::numeric_limits<std::uint32_t>::max()) return Error{where + "too many indices"};
  for (std::size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= nv)
      return Error{where + "index " + std::to_string(i) + " = " + std::to_string(mesh.indices[i]) + " out of range (" +
                   std::to_string(nv) + " vertices)"};
  PreparedMeshChunk out;
  out.vertices.resize(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    const glm::vec3& p = mesh.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return Error{where + "vertex " + std::to_string(i) + " has a non-finite position"};
    out.vertices[i] = {{p.x, p.y, p.z}, {mesh.colors[i].r, mesh.colors[i].g, mesh.colors[i].b, 255}};
  }
  out.indices.assign(mesh.indices.begin(), mesh.indices.end());
  return out;
}

Status MeshPass::set_chunk(vk::Context& context, std::uint64_t id, const TriangleMesh& mesh, const MeshUpdate& via) {
  if (mesh.positions.empty() && mesh.indices.empty()) {
    remove_chunk(id, via);
    return Ok{};
  }
  auto prepared = prepare_mesh_chunk(id, mesh);
  if (!prepared) return prepared.error();
  return set_chunk(context, id, *prepared, via);
}

Status MeshPass::set_chunk(vk::Context& context, std::uint64_t id, const PreparedMeshChunk& prepared,
                           const MeshUpdate& via) {
  if (prepared.vertices.empty() || prepared.indices.empty()) return Error{"MeshPass::set_chunk: the mesh is empty"};
  auto vb = vk::Buffer::create(context, {.size = prepared.vertices.size() * sizeof(MeshVertex),
                                         .usage = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                         .name = "mesh vertices"});
  if (!vb) return vb.error();
  auto ib = vk::Buffer::create(context, {.size = prepared.indices.size() * sizeof(std::uint32_t),
                                         .usage = VK_BUFFER_USAGE_INDEX_BUFFER_BIT,
                                         .name = "mesh indices"});
  if (!ib) return ib.error();
  // Fresh buffers: no frame reads them yet, but the copies must land before the frame that
  // first draws them, so a frame-paced caller stages them with that frame's other writes.
  auto put = [&](vk::Buffer& b, const void* data) -> Status {
    return via.uploads != nullptr ? via.uploads->write(b, 0, data, b.size()) : b.upload(data, b.size());
  };
  if (auto st = put(*vb, prepared.vertices.data()); !st) return st;
  if (auto st = put(*ib, prepared.indices.data()); !st) return st;
  Chunk chunk{std::make_shared<vk::Buffer>(std::move(*vb)), std::make_shared<vk::Buffer>(std::move(*ib)),
              static_cast<std::uint32_t>(prepared.indices.size())};
  auto it = chunks_.find(id);
  if (it != chunks_.end()) {
    retire(std::move(it->second), via);
    it->second = std::move(chunk);
  } else {
    chunks_.emplace(id, std::move(chunk));
  }
  return Ok{};
}

void MeshPass::remove_chunk(std::uint64_t id, const MeshUpdate& via) noexcept {
  auto it = chunks_.find(id);
  if (it == chunks_.end()) return;
  retire(std::move(it->second), via);
  chunks_.erase(it);
}

void MeshPass::clear_mesh(const MeshUpdate& via) noexcept {
  for (auto& [id, chunk] : chunks_) retire(std::move(chunk), via);
  chunks_.clear();
}

std::uint64_t MeshPass::triangle_count() const noexcept {
  std::uint64_t n = 0;
  for (const auto& [id, chunk] : chunks_) n += chunk.index_count / 3;
  return n;
}

void MeshPass::retire(Chunk chunk, const MeshUpdate& via) noexcept {
  if (via.ring == nullptr) return;  // the Buffers' destructors wait for the device
  via.ring->defer([chunk = std::move(chunk)]() {
    chunk.vertices->destroy_after_gpu_finished();
    chunk.indices->destroy_after_gpu_finished();
  });
}

void MeshPass::record(VkCommandBuffer cmd, vk::OffscreenTarget& target, const Camera& camera,
                      const glm::vec3& clear_colour) const {
  vk::ClearValues clear;
  clear.color[0] = clear_colour.r;
  clear.color[1] = clear_colour.g;
  clear.color[2] = clear_colour.b;
  clear.color[3] = 1.0f;
  clear.depth = 1.0f;
  target.begin_rendering(cmd, true, clear);
  gpu::GpuMeshPush push{};
  const glm::dmat4& m = camera.world_to_camera;
  push.w2c_row0 = glm::vec4(m[0][0], m[1][0], m[2][0], m[3][0]);
  push.w2c_row1 = glm::vec4(m[0][1], m[1][1], m[2][1], m[3][1]);
  push.w2c_row2 = glm::vec4(m[0][2], m[1][2], m[2][2], m[3][2]);
  push.intrinsics = glm::vec4(camera.fx, camera.fy, camera.cx, camera.cy);
  const double near = camera.near_plane > 0.0 ? camera.near_plane : kNearCull;
  const double far = std::min<double>(gpu::SPLAT_MESH_DEPTH_SCALE, camera.far_plane > near ? camera.far_plane
                                                                                          : gpu::SPLAT_MESH_DEPTH_SCALE);
  push.viewport = glm::vec4(camera.width, camera.height, near, far);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.handle());
  pipeline_.push_constants(cmd, push);
  const VkDeviceSize offset = 0;
  for (const auto& [id, chunk] : chunks_) {  // ascending id: equal depths keep a fixed order
    const VkBuffer vb = chunk.vertices->handle();
    vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &offset);
    vkCmdBindIndexBuffer(cmd, chunk.indices->handle(), 0, VK_INDEX_TYPE_UINT32);
    vkCmdDrawIndexed(cmd, chunk.index_count, 1, 0, 0, 0);
  }
  target.end_rendering(cmd);
}

float MeshPass::stored_to_view_depth(float stored) noexcept {
  if (!(stored < 1.0f)) return std::numeric_limits<float>::infinity();
  return stored * gpu::SPLAT_MESH_DEPTH_SCALE;
}

}  // namespace gauss::render
