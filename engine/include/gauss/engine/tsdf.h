#pragma once
// Truncated signed distance fusion on sparse voxel blocks, and marching-cubes
// extraction into mesh chunks that flow to clients as surface edits.
//
// The volume is a hash map of 8x8x8-voxel blocks allocated where depth was observed.
// A voxel holds the weighted mean of projective signed distances (positive in free
// space, truncated to [-1, 1] in units of the truncation distance), its weight and a
// weighted mean colour. Chunks group chunk_blocks^3 blocks; a chunk is re-extracted
// only when a block it reads changed since the last extraction.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/mat4x4.hpp>

#include "gauss/engine/camera.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/image_io.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/result.h"

namespace gauss {

struct TsdfConfig {
  float voxel_size{0.02f};           // metres
  float truncation{0.0f};            // metres; 0 = 3 voxels (wider bands blur real, noisy frames)
  float min_depth{0.1f};             // depths outside [min, max] are treated as missing
  float max_depth{8.0f};
  float max_weight{64.0f};           // running-average cap so the surface can still move
  std::uint32_t max_blocks{200000};  // memory bound (~6 KiB each); a frame needing more is refused
  std::uint32_t chunk_blocks{2};     // chunk edge length in blocks: small patches, few draw ranges
};

// One RGB-D observation. depth is metres per pixel (0 or NaN = missing).
struct RgbdFrame {
  std::string name;                  // named in every error about this frame
  std::uint32_t width{0}, height{0};
  std::vector<float> depth;          // width * height
  ImageRGBA8 colour;                 // optional: empty, or width x height
  double fx{0}, fy{0}, cx{0}, cy{0};
  glm::dmat4 camera_to_world{1.0};   // rigid
  Epoch epoch{0};                    // the source epoch this frame belongs to
};

enum class SurfaceEditKind : std::uint8_t { Add = 0, Replace = 1, Remove = 2 };

struct SurfaceEdit {
  SurfaceEditKind kind{SurfaceEditKind::Add};
  std::uint32_t chunk_id{0};         // assigned when a chunk is first seen, stable for the volume's life
  Epoch epoch{0};                    // newest frame epoch fused into the chunk's blocks
  TriangleMesh mesh;                 // empty for Remove
};

struct TsdfStats {
  std::size_t blocks{0};
  std::size_t bytes{0};
  std::size_t frames_integrated{0};
  std::size_t frames_rejected{0};
};

class SceneStore;
class SyntheticScene;

// The pinhole camera a frame was taken with (for rendering a mesh back into it).
Camera frame_camera(const RgbdFrame& frame);

// Applies surface edits to the host scene (inside its open epoch): Add/Replace set the
// chunk, Remove drops it. Stops at the first edit the store refuses and returns its error.
Status apply_surface_edits(SceneStore& store, const std::vector<SurfaceEdit>& edits);

// The synthetic scene's exact ground-truth depth and colour for `camera` as an RGB-D
// frame, so the embedded default scene gets a fused surface like a real capture.
RgbdFrame synthetic_rgbd_frame(const SyntheticScene& scene, const Camera& camera, Epoch epoch);

class TsdfVolume {
 public:
  static Expected<TsdfVolume> create(const TsdfConfig& config);
  TsdfVolume(TsdfVolume&&) noexcept;
  TsdfVolume& operator=(TsdfVolume&&) noexcept;
  ~TsdfVolume();

  // Fuses one frame. Every check runs before anything is written: a wrong-size image,
  // a NaN or non-rigid pose, bad intrinsics, negative or absurd depths, or a frame
  // that would exceed max_blocks returns an error naming the frame and leaves the
  // volume exactly as it was.
  Status integrate(const RgbdFrame& frame);

  // Re-extracts the chunks whose blocks changed since the last call and returns them as
  // edits: Add for a new non-empty chunk, Replace for a changed one, Remove for a chunk
  // that became empty. Vertices are shared within a chunk; chunks meet without cracks.
  std::vector<SurfaceEdit> extract_changed();

  // The mesh of one chunk as it stands now (empty for an unknown id).
  TriangleMesh chunk_mesh(std::uint32_t chunk_id) const;

  // The whole current surface as one mesh (all chunks, concatenated).
  TriangleMesh extract_all() const;

  // Signed distance (metres) and weight at a world point, trilinear; weight 0 = unobserved.
  float sample(const glm::vec3& world, float* out_weight = nullptr) const;

  const TsdfConfig& config() const;
  TsdfStats stats() const;

 private:
  struct Impl;
  explicit TsdfVolume(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gauss
