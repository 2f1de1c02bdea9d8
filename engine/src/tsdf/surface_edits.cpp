// Glue between the TSDF and the rest of the host: surface edits into the scene store,
// and the synthetic scene's ground truth as RGB-D frames.
#include "gauss/engine/scene_store.h"
#include "gauss/engine/synthetic_scene.h"
#include "gauss/engine/tsdf.h"

namespace gauss {

Status apply_surface_edits(SceneStore& store, const std::vector<SurfaceEdit>& edits) {
  for (const SurfaceEdit& e : edits) {
    if (e.kind == SurfaceEditKind::Remove) {
      if (auto st = store.remove_surface_chunk(e.chunk_id); !st) return st;
      continue;
    }
    if (auto st = store.set_surface_chunk(SurfaceChunk{e.chunk_id, e.epoch, e.mesh}); !st) return st;
  }
  return Ok{};
}

Camera frame_camera(const RgbdFrame& frame) {
  Camera cam;
  cam.width = frame.width;
  cam.height = frame.height;
  cam.fx = frame.fx;
  cam.fy = frame.fy;
  cam.cx = frame.cx;
  cam.cy = frame.cy;
  cam.world_to_camera = glm::inverse(frame.camera_to_world);
  return cam;
}

RgbdFrame synthetic_rgbd_frame(const SyntheticScene& scene, const Camera& camera, Epoch epoch) {
  GroundTruthImage gt = scene.render_ground_truth(camera);
  RgbdFrame f;
  f.name = "synthetic variant " + std::to_string(scene.config().variant) + " epoch " +
           std::to_string(to_underlying(epoch));
  f.width = camera.width;
  f.height = camera.height;
  f.depth = std::move(gt.depth);
  f.colour = std::move(gt.colour);
  f.fx = camera.fx;
  f.fy = camera.fy;
  f.cx = camera.cx;
  f.cy = camera.cy;
  f.camera_to_world = glm::inverse(camera.world_to_camera);
  f.epoch = epoch;
  return f;
}

}  // namespace gauss
