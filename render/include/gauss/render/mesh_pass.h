#pragma once
// gauss::render::MeshPass: rasterizes the TSDF surface mesh (vertex colours) into an
// OffscreenTarget: colour = the splats' background, depth attachment = the linear VIEW
// depth t.z / SPLAT_MESH_DEPTH_SCALE (shaders/shared/splat_layout.h), exact and cleared to
// 1.0 (= no triangle). The splat passes read both (splat_math.h "Mesh").
// Pixel (i, j) samples (j + 0.5, i + 0.5) with the OpenCV projection, like the splats.
//
// The surface is a set of chunks keyed by id (the TSDF's chunks as they stream in:
// add / replace / remove), drawn in ascending id order in one pass; set_mesh() is the
// one-chunk case. Buffers of a replaced or removed chunk may still be read by frames in
// flight: with a MeshUpdate naming the renderer's FrameRing and StagedUploads they are
// uploaded through the staging ring and destroyed only after those frames finished;
// without one (standalone use, nothing in flight) uploads are direct.
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/result.h"
#include "gauss/render/vk_buffer.h"
#include "gauss/render/vk_image.h"
#include "gauss/render/vk_pipeline.h"

namespace gauss::vk {
class Context;
class FrameRing;
class StagedUploads;
}

namespace gauss::render {

// One vertex as the mesh pass reads it (binding 0): position (R32G32B32_SFLOAT) + colour
// (R8G8B8A8_UNORM).
struct MeshVertex {
  float position[3];
  std::uint8_t colour[4];
};
static_assert(sizeof(MeshVertex) == 16);

// A chunk checked and in the pass's vertex layout: what set_chunk uploads. Made without
// Vulkan, so a publication thread can prepare it while the display renders.
struct PreparedMeshChunk {
  std::vector<MeshVertex> vertices;
  std::vector<std::uint32_t> indices;
};
// Errors (naming chunk `id`): colours not one per position, an index count not a multiple
// of 3, an index out of range, a non-finite position, an empty mesh.
Expected<PreparedMeshChunk> prepare_mesh_chunk(std::uint64_t id, const TriangleMesh& mesh);

// How a chunk change reaches the GPU (both null: direct, for standalone use).
struct MeshUpdate {
  vk::StagedUploads* uploads{nullptr};
  vk::FrameRing* ring{nullptr};
};

class MeshPass {
 public:
  static Expected<MeshPass> create(vk::Context& context);

  MeshPass() = default;
  MeshPass(MeshPass&&) noexcept = default;
  MeshPass& operator=(MeshPass&&) noexcept = default;

  // Uploads a mesh as the only chunk (id 0), replacing every chunk. Errors, with nothing
  // changed: colours not one per position, an index count not a multiple of 3, an index
  // out of range, a non-finite position, an empty mesh.
  Status set_mesh(vk::Context& context, const TriangleMesh& mesh, const MeshUpdate& via = {});
  // Adds or replaces chunk `id` (same checks as set_mesh; an empty mesh removes it).
  Status set_chunk(vk::Context& context, std::uint64_t id, const TriangleMesh& mesh, const MeshUpdate& via = {});
  // Adds or replaces chunk `id` with a prepared one (buffers and their uploads only).
  Status set_chunk(vk::Context& context, std::uint64_t id, const PreparedMeshChunk& chunk, const MeshUpdate& via = {});
  // Removes chunk `id` (absent: nothing happens).
  void remove_chunk(std::uint64_t id, const MeshUpdate& via = {}) noexcept;
  void clear_mesh(const MeshUpdate& via = {}) noexcept;
  bool has_mesh() const noexcept { return !chunks_.empty(); }
  std::size_t chunk_count() const noexcept { return chunks_.size(); }
  std::uint64_t triangle_count() const noexcept;

  // Records the pass into `target` (cleared to clear_colour and depth 1.0 first). Leaves
  // colour in COLOR_ATTACHMENT layout and depth in DEPTH_ATTACHMENT layout. Near/far from
  // the camera (fragments outside are clipped). Requires has_mesh().
  void record(VkCommandBuffer cmd, vk::OffscreenTarget& target, const Camera& camera,
              const glm::vec3& clear_colour) const;

  // Converts a depth attachment value read back from the target into metres
  // (+infinity where no triangle covers the pixel).
  static float stored_to_view_depth(float stored) noexcept;

 private:
  struct Chunk {
    std::shared_ptr<vk::Buffer> vertices;
    std::shared_ptr<vk::Buffer> indices;
    std::uint32_t index_count{0};
  };
  // Destroys a chunk's buffers now (direct) or after the frames in flight (via.ring).
  static void retire(Chunk chunk, const MeshUpdate& via) noexcept;

  vk::GraphicsPipeline pipeline_;
  std::map<std::uint64_t, Chunk> chunks_;
};

}  // namespace gauss::render
