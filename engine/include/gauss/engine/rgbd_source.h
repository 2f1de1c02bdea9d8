#pragma once
// RGB-D frame sources for TSDF fusion: folders in the 3DMatch/SUN3D layout and the
// TUM RGB-D layout. Frames are listed when the folder is opened and loaded one at a
// time; a bad frame is an error naming it, and the caller decides to skip it.
//
// 3DMatch/SUN3D: camera-intrinsics.txt (3x3 K) at the top, frames in the top folder
//   or in seq-*/ subfolders: frame-N.color.png (8-bit), frame-N.depth.png (16-bit,
//   millimetres, 0 = missing), frame-N.pose.txt (4x4 camera-to-world).
// TUM: rgb.txt and depth.txt ("timestamp path" lines), groundtruth.txt ("timestamp tx ty
//   tz qx qy qz qw"), depth PNGs scaled by 5000 per metre. Depth frames are paired with
//   the nearest colour image and pose within 20 ms; unpaired frames are not listed.
//   Intrinsics come from an optional camera-intrinsics.txt, else the TUM "ROS default"
//   (fx = fy = 525, cx = 319.5, cy = 239.5).
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include "gauss/engine/result.h"
#include "gauss/engine/tsdf.h"

namespace gauss {

enum class RgbdLayout { ThreeDMatch, Tum };

class RgbdFolderSource {
 public:
  // Detects the layout; errors for a missing folder, missing index files or no frames.
  static Expected<RgbdFolderSource> open(const std::filesystem::path& folder);

  RgbdLayout layout() const { return layout_; }
  std::size_t frame_count() const { return frames_.size(); }
  const std::string& frame_name(std::size_t i) const { return frames_[i].name; }
  // Loads frame i (depth in metres, colour, intrinsics, pose) tagged with `epoch`.
  Expected<RgbdFrame> load(std::size_t i, Epoch epoch) const;

 private:
  struct FrameFiles {
    std::string name;
    std::filesystem::path colour, depth, pose_file;
    glm::dmat4 pose{1.0};  // TUM: from groundtruth.txt; 3DMatch: read from pose_file
  };
  RgbdLayout layout_{RgbdLayout::ThreeDMatch};
  double fx_{0}, fy_{0}, cx_{0}, cy_{0};
  double depth_scale_{1000.0};  // raw units per metre
  std::vector<FrameFiles> frames_;
};

// Reads a whitespace-separated 3x3 intrinsics matrix (fx 0 cx / 0 fy cy / 0 0 1).
Status read_intrinsics(const std::filesystem::path& path, double& fx, double& fy, double& cx, double& cy);
// Reads a whitespace-separated 4x4 row-major rigid transform.
Expected<glm::dmat4> read_pose_4x4(const std::filesystem::path& path);

}  // namespace gauss
