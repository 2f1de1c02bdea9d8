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
#include "gauss/shaders/mesh.frag.spv.h"
#include "gauss/shaders/mesh.vert.spv.h"
#include "splat_layout.h"

namespace gauss::render {

namespace {

struct MeshVertex {  // binding 0: position (R32G32B32_SFLOAT) + colour (R8G8B8A8_UNORM)
  float position[3];
  std::uint8_t colour[4];
};
static_assert(sizeof(MeshVertex) == 16);

}  // namespace

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

Status MeshPass::set_mesh(vk::Context& context, const TriangleMesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  if (nv == 0 || mesh.indices.empty()) return Error{"MeshPass::set_mesh: the mesh is empty"};
  if (mesh.colors.size() != nv)
    return Error{"MeshPass::set_mesh: " + std::to_string(mesh.colors.size()) + " colours for " + std::to_string(nv) +
                 " positions"};
  if (mesh.indices.size() % 3 != 0)
    return Error{"MeshPass::set_mesh: index count " + std::to_string(mesh.indices.size()) +
                 " is not a multiple of 3"};
  if (mesh.indices.size() > std::numeric_limits<std::uint32_t>::max())
    return Error{"MeshPass::set_mesh: too many indices"};
  for (std::size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= nv)
      return Error{"MeshPass::set_mesh: index " + std::to_string(i) + " = " + std::to_string(mesh.indices[i]) +
                   " out of range (" + std::to_string(nv) + " vertices)"};
  std::vector<MeshVertex> vertices(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    const glm::vec3& p = mesh.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return Error{"MeshPass::set_mesh: vertex " + std::to_string(i) + " has a non-finite position"};
    vertices[i] = {{p.x, p.y, p.z}, {mesh.colors[i].r, mesh.colors[i].g, mesh.colors[i].b, 255}};
  }
  auto vb = vk::Buffer::create(context, {.size = nv * sizeof(MeshVertex),
                                         .usage = VK_BUFFER_USAGE_VERTEX_BUFFER_BIT,
                                         .name = "mesh vertices"});
  if (!vb) return vb.error();
  auto ib = vk::Buffer::create(context, {.size = mesh.indices.size() * sizeof(std::uint32_t),
                                         .usage = VK_BUFFER_USAGE_INDEX_BUFFER_BIT,
                                         .name = "mesh indices"});
  if (!ib) return ib.error();
  if (auto st = vb->upload(vertices.data(), vb->size()); !st) return st;
  if (auto st = ib->upload(mesh.indices.data(), ib->size()); !st) return st;
  vertices_ = std::move(*vb);
  indices_ = std::move(*ib);
  index_count_ = static_cast<std::uint32_t>(mesh.indices.size());
  return Ok{};
}

void MeshPass::clear_mesh() noexcept {
  vertices_ = vk::Buffer{};
  indices_ = vk::Buffer{};
  index_count_ = 0;
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
  const VkBuffer vb = vertices_.handle();
  vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &offset);
  vkCmdBindIndexBuffer(cmd, indices_.handle(), 0, VK_INDEX_TYPE_UINT32);
  vkCmdDrawIndexed(cmd, index_count_, 1, 0, 0, 0);
  target.end_rendering(cmd);
}

float MeshPass::stored_to_view_depth(float stored) noexcept {
  if (!(stored < 1.0f)) return std::numeric_limits<float>::infinity();
  return stored * gpu::SPLAT_MESH_DEPTH_SCALE;
}

}  // namespace gauss::render
