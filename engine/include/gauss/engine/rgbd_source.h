#pragma once
// RGB-D frame sources for TSDF fusion: folders in the 3DMatch/SUN3D, TUM RGB-D and Replica
// layouts, recognised by their index files (TUM: rgb.txt + depth.txt; Replica: traj.txt +
// results/; else 3DMatch). Frames are listed when the folder is opened and loaded one at a
// time; a bad frame (unreadable image, missing pose, colour and depth of different sizes)
// is an error naming it, and the caller decides to skip it. Colour is optional in every
// layout (a frame without its colour image fuses grey) and may be a PNG or a JPEG.
//
// 3DMatch/SUN3D: camera-intrinsics.txt (3x3 K) at the top, frames in the top folder
//   or in seq-*/ subfolders: frame-N.color.png (8-bit), frame-N.depth.png (16-bit,
//   millimetres, 0 = missing), frame-N.pose.txt (4x4 camera-to-world).
// TUM: rgb.txt and depth.txt ("timestamp path" lines), groundtruth.txt ("timestamp tx ty
//   tz qx qy qz qw"), depth PNGs scaled by 5000 per metre. Depth frames are paired with
//   the nearest colour image and pose within 20 ms; unpaired frames are not listed.
//   Intrinsics come from an optional camera-intrinsics.txt, else the TUM "ROS default"
//   (fx = fy = 525, cx = 319.5, cy = 239.5).
// Replica (as NICE-SLAM renders it): results/depthNNNNNN.png (16-bit, 0 = missing) with
//   results/frameNNNNNN.jpg (or .png), traj.txt whose line N+1 is frame N's row-major 4x4
//   camera-to-world, and cam_params.json {"camera": {"w", "h", "fx", "fy", "cx", "cy",
//   "scale"}} (scale = depth units per metre, 6553.5 there) in the folder or, as NICE-SLAM
//   keeps one for all rooms, in its parent. Depth images must be w x h. Frames are those
//   with a depth image, in frame-number order; a frame past the end of traj.txt (or on a
//   malformed line) fails to load, naming the frame and the line.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "gauss/engine/result.h"
#include "gauss/engine/tsdf.h"

namespace gauss {

enum class RgbdLayout { ThreeDMatch, Tum, Replica };

// "3DMatch", "TUM", "Replica" (for messages and summaries).
const char* rgbd_layout_name(RgbdLayout layout);

class RgbdFolderSource {
 public:
  // Detects the layout; errors for a missing folder, missing index files or no frames.
  static Expected<RgbdFolderSource> open(const std::filesystem::path& folder);

  RgbdLayout layout() const { return layout_; }
  std::size_t frame_count() const { return frames_.size(); }
  const std::string& frame_name(std::size_t i) const { return frames_[i].name; }
  // Frame i's camera-to-world pose alone (read from its file in the 3DMatch layout).
  Expected<glm::dmat4> frame_pose(std::size_t i) const;
  // Loads frame i (depth in metres, colour, intrinsics, pose) tagged with `epoch`.
  Expected<RgbdFrame> load(std::size_t i, Epoch epoch) const;

 private:
  struct FrameFiles {
    std::string name;
    std::filesystem::path colour, depth, pose_file;
    glm::dmat4 pose{1.0};  // TUM, Replica: from the index; 3DMatch: read from pose_file
    std::string pose_error;  // Replica: why this frame has no pose (load fails with it)
  };
  // Each lists one layout's frames (and intrinsics) into `src`; errors name the index file.
  static Status list_tum(const std::filesystem::path& folder, RgbdFolderSource& src);
  static Status list_replica(const std::filesystem::path& folder, RgbdFolderSource& src);
  static Status list_3dmatch(const std::filesystem::path& folder, RgbdFolderSource& src);

  RgbdLayout layout_{RgbdLayout::ThreeDMatch};
  double fx_{0}, fy_{0}, cx_{0}, cy_{0};
  double depth_scale_{1000.0};  // raw units per metre
  std::uint32_t width_{0}, height_{0};  // Replica: the size every depth image must have; 0 = any
  std::vector<FrameFiles> frames_;
};

// Reads a whitespace-separated 3x3 intrinsics matrix (fx 0 cx / 0 fy cy / 0 0 1).
Status read_intrinsics(const std::filesystem::path& path, double& fx, double& fy, double& cx, double& cy);
// Reads a whitespace-separated 4x4 row-major rigid transform.
Expected<glm::dmat4> read_pose_4x4(const std::filesystem::path& path);

}  // namespace gauss
