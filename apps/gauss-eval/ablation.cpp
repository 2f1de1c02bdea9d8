// The budget ablation: PC-HS fidelity against the client's budget M (and the view size),
// with the client's frame time beside it.
//
// For each size in --ablation-sizes (default: --size) and each M in --ablation (with --lod
// both, twice: with the LoD cut and without): a fresh connection at M; at each fidelity camera the client settles, then renders kAblationIdleFrames
// more frames at the view (their GPU pass times are the frame time at that M: the cost of
// drawing the resident set, without publication). PC-HS / GT-HS per camera as in the
// fidelity chain; the means over the cameras are the ablation point.
#include <chrono>
#include <cmath>

#include "measurements.h"

namespace gauss::eval_app {

namespace {

constexpr int kAblationIdleFrames = 8;

// The mean of `key` over the cameras' scores at `field`; null when a camera has none (no
// pixel, or identical images: a mean with +inf says nothing).
Json mean_of(const Json& cameras, const char* field, const char* key) {
  double sum = 0.0;
  std::size_t n = 0;
  for (const Json& c : cameras) {
    const Json& v = c[field].contains(key) ? c[field][key] : Json();
    if (!v.is_number()) return nullptr;
    sum += v.get<double>();
    ++n;
  }
  return n ? Json(sum / double(n)) : Json(nullptr);
}

// The mean of a number every camera has.
Json mean_value(const Json& cameras, const char* key) {
  double sum = 0.0;
  for (const Json& c : cameras) sum += c[key].get<double>();
  return cameras.empty() ? Json(nullptr) : Json(sum / double(cameras.size()));
}

}  // namespace

Expected<Json> measure_ablation(Room& room, std::vector<double>& frame_ms_p50, std::vector<double>& frame_ms_p95) {
  const auto t0 = std::chrono::steady_clock::now();
  const Options& o = room.options;
  const EvalScene& scene = room.scene;
  Json points = Json::array();
  for (const auto& [w, h] : o.ablation_sizes) {
    auto full = make_full_renderer(room.context, scene, w, h);
    if (!full) return full.error();
    Options sized = o;
    sized.width = w;
    sized.height = h;
    Room at_size{room.context, sized, scene, **full, room.panels, room.timing, room.progress};
    // --lod both: each M with the LoD cut and without it, in that order.
    std::vector<bool> lods{o.lod_on()};
    if (o.lod == "both") lods.push_back(false);
    for (std::uint32_t m : o.ablation_budgets)
    for (bool lod : lods) {
      auto stream = open_stream(at_size, m, o.progressive ? PublishMode::Progressive : PublishMode::Immediate,
                                false, lod);
      if (!stream) return stream.error();
      Json cameras = Json::array();
      std::vector<double> gpu_ms;
      for (std::size_t k = 0; k < scene.cameras.size(); ++k) {
        room.progress("ablation " + std::to_string(w) + "x" + std::to_string(h) + " M " + std::to_string(m) +
                      (lod ? " LoD" : "") + " camera " + std::to_string(k + 1) + "/" + std::to_string(scene.cameras.size()));
        const Camera cam = resized_camera(scene.cameras[k], w, h);
        auto cap = capture(at_size, *stream, cam);
        if (!cap) return cap.error();
        EvalSession& session = *stream->session;
        const std::uint64_t first_idle = session.client().frames_rendered();
        for (int i = 0; i < kAblationIdleFrames; ++i)
          if (auto f = session.step(cam); !f) return f.error();
        if (auto st = session.client().wait_frames(); !st) return st.error();
        for (const client::GpuFrameStats& g : session.client().take_gpu_stats())
          if (g.frame_index >= first_idle) gpu_ms.push_back(g.total_ms);
        const std::optional<GroundTruthImage> gt = ground_truth(scene, cam);
        auto pc = render_covered(**full, cam);
        if (!pc) return pc.error();
        cameras.push_back(Json{{"camera", k},
                               {"settle", settle_json(cap->settle)},
                               {"resident", cap->resident},
                               {"coverage_hs", fraction(cap->sent.cover)},
                               {"pc_hs", scores(pc->image, cap->hs, mask_and(pc->cover, cap->sent.cover))},
                               {"pc_hs_all", scores(pc->image, cap->hs, pc->cover)},
                               {"gt_hs", gt ? scores(gt->colour, cap->hs, valid_depth_mask(*gt)) : Json(nullptr)},
                               {"hs_vs_sent_differing", cap->hs_vs_sent_differing}});
      }
      frame_ms_p50.push_back(percentile_of(gpu_ms, 0.5));
      frame_ms_p95.push_back(percentile_of(gpu_ms, 0.95));
      points.push_back(Json{{"budget", m},
                            {"lod", lod},
                            {"width", w},
                            {"height", h},
                            {"psnr_pc_hs", mean_of(cameras, "pc_hs", "psnr_db")},
                            {"ssim_pc_hs", mean_of(cameras, "pc_hs", "ssim")},
                            {"flip_pc_hs", mean_of(cameras, "pc_hs", "flip")},
                            {"psnr_gt_hs", mean_of(cameras, "gt_hs", "psnr_db")},
                            {"psnr_pc_hs_all", mean_of(cameras, "pc_hs_all", "psnr_db")},
                            {"coverage_hs", mean_value(cameras, "coverage_hs")},
                            {"cameras", std::move(cameras)}});
    }
  }
  room.timing.phases["ablation_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return points;
}

}  // namespace gauss::eval_app
