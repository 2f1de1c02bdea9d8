// The fidelity chain GT -> PC -> HS at the room's cameras, and what every measurement
// shares: opening a stream, capturing a settled view.
#include <algorithm>
#include <chrono>

#include "measurements.h"

namespace gauss::eval_app {

namespace {

// Interior LoD records among the host's sent set.
std::uint64_t lod_interior(const EvalSession& session) {
  const auto& ids = session.host().sent_ids();
  return static_cast<std::uint64_t>(std::count_if(ids.begin(), ids.end(), is_lod_interior_id));
}

}  // namespace

void Timing::add_gpu(const std::vector<client::GpuFrameStats>& frames) {
  for (const client::GpuFrameStats& g : frames) {
    frame_gpu_ms.push_back(g.total_ms);
    render::SplatPassTimings sum;
    for (std::uint32_t v = 0; v < g.views; ++v) {
      const render::SplatPassTimings& t = g.view[v].gpu;
      sum.mesh_ms += t.mesh_ms;
      sum.preprocess_ms += t.preprocess_ms;
      sum.compact_ms += t.compact_ms;
      sum.depth_sort_ms += t.depth_sort_ms;
      sum.emit_ms += t.emit_ms;
      sum.tile_sort_ms += t.tile_sort_ms;
      sum.ranges_ms += t.ranges_ms;
      sum.blend_ms += t.blend_ms;
      sum.upload_ms += t.upload_ms;
    }
    pass_gpu_ms["upload"].push_back(sum.upload_ms);
    pass_gpu_ms["mesh"].push_back(sum.mesh_ms);
    pass_gpu_ms["preprocess"].push_back(sum.preprocess_ms);
    pass_gpu_ms["compact"].push_back(sum.compact_ms);
    pass_gpu_ms["depth_sort"].push_back(sum.depth_sort_ms);
    pass_gpu_ms["emit"].push_back(sum.emit_ms);
    pass_gpu_ms["tile_sort"].push_back(sum.tile_sort_ms);
    pass_gpu_ms["ranges"].push_back(sum.ranges_ms);
    pass_gpu_ms["blend"].push_back(sum.blend_ms);
  }
}

EvalSessionConfig session_config(const Options& o, std::uint32_t budget, PublishMode mode) {
  EvalSessionConfig sc;
  sc.budget = budget;
  sc.width = o.width;
  sc.height = o.height;
  sc.mode = mode;
  sc.allowance = o.allowance;
  sc.display_hz = o.display_hz;
  sc.down.latency_s = sc.up.latency_s = o.latency_ms * 1e-3;
  sc.down.bandwidth_bps = sc.up.bandwidth_bps = o.bandwidth_mbps * 1e6;
  sc.seed = o.seed;
  sc.default_rho = o.rho;
  sc.lod = o.lod_on();
  return sc;
}

Expected<Stream> open_stream(Room& room, std::uint32_t budget, PublishMode mode, bool publication_thread,
                             std::optional<bool> lod) {
  const Options& o = room.options;
  EvalSessionConfig sc = session_config(o, budget, mode);
  sc.publication_thread = publication_thread;
  if (lod) sc.lod = *lod;
  Stream s;
  auto session = EvalSession::create(room.context, *room.scene.store, room.scene.codec, sc);
  if (!session) return session.error();
  s.session = std::move(*session);
  auto sent = make_sent_renderer(room.context, room.scene, budget, o.width, o.height);
  if (!sent) return sent.error();
  s.sent = std::move(*sent);
  return s;
}

Expected<ClientCapture> capture(Room& room, Stream& stream, const Camera& camera,
                                const std::function<void(const client::DisplayFrameStats&)>& on_frame) {
  auto cap = capture_client(*stream.session, *stream.sent, camera, room.options, on_frame);
  if (!cap) return cap.error();
  room.timing.frame_cpu_ms.insert(room.timing.frame_cpu_ms.end(), cap->settle.frame_cpu_ms.begin(),
                                  cap->settle.frame_cpu_ms.end());
  room.timing.add_gpu(stream.session->client().take_gpu_stats());
  return cap;
}

Status add_fidelity_chain(Room& room, const Camera& cam, const ImageRGBA8& hs, const eval::Mask& hs_cover,
                          const std::string& panel, Json& out) {
  const EvalScene& scene = room.scene;
  const std::optional<GroundTruthImage> gt = ground_truth(scene, cam);
  auto pc = render_covered(room.full, cam);
  if (!pc) return Error{"the host's full render: " + pc.message()};
  const eval::Mask valid = gt ? valid_depth_mask(*gt) : eval::Mask{};
  const eval::Mask both = mask_and(pc->cover, hs_cover);
  // Without ground truth the GT-referenced figures are null ("n/a" in the report).
  out["gt_pc"] = gt ? scores(gt->colour, pc->image, valid) : Json(nullptr);
  out["gt_hs"] = gt ? scores(gt->colour, hs, valid) : Json(nullptr);
  out["pc_hs"] = scores(pc->image, hs, both);
  out["pc_hs_all"] = scores(pc->image, hs, pc->cover);
  out["coverage"] = Json{{"gt_valid", gt ? Json(fraction(valid)) : Json(nullptr)},
                         {"pc", fraction(pc->cover)},
                         {"hs", fraction(hs_cover)},
                         {"both", fraction(both)}};
  if (!room.panels.enabled() || panel.empty()) return Ok{};
  auto fm = eval::flip_map(view_of(pc->image), view_of(hs));
  if (!fm) return Error{"FLIP map: " + fm.message()};
  const ImageRGBA8 diff = flip_image(*fm, cam.width, cam.height);
  std::vector<const ImageRGBA8*> images{&pc->image, &hs, &diff};
  if (gt) images.insert(images.begin(), &gt->colour);
  return room.panels.write(panel, images);
}

Expected<Json> measure_fidelity(Room& room) {
  const auto t0 = std::chrono::steady_clock::now();
  const EvalScene& scene = room.scene;
  const Options& o = room.options;
  const PublishMode mode = o.progressive ? PublishMode::Progressive : PublishMode::Immediate;
  auto stream = open_stream(room, o.budget, mode);
  if (!stream) return Error{scene.name + ": " + stream.message()};
  // --lod both: the same cameras again on a connection without LoD, side by side.
  std::optional<Stream> leaf_only;
  if (o.lod == "both") {
    auto s = open_stream(room, o.budget, mode, false, false);
    if (!s) return Error{scene.name + " without LoD: " + s.message()};
    leaf_only = std::move(*s);
  }
  Json cameras = Json::array();
  for (std::size_t k = 0; k < scene.cameras.size(); ++k) {
    const Camera& cam = scene.cameras[k];
    room.progress("fidelity camera " + std::to_string(k + 1) + "/" + std::to_string(scene.cameras.size()));
    auto cap = capture(room, *stream, cam);
    if (!cap) return Error{scene.name + " camera " + std::to_string(k) + ": " + cap.message()};
    Json c;
    c["camera"] = k;
    c["pose"] = camera_json(cam);
    c["settle"] = settle_json(cap->settle);
    c["resident"] = cap->resident;
    c["desired"] = cap->desired;
    c["lod_interior"] = lod_interior(*stream->session);
    const std::string where = scene.name + " camera " + std::to_string(k);
    if (auto st = add_fidelity_chain(room, cam, cap->hs, cap->sent.cover, scene.name + "_cam" + std::to_string(k), c);
        !st)
      return Error{where + ": " + st.message()};
    c["hs_vs_sent"] = Json{{"differing_pixels", cap->hs_vs_sent_differing},
                           {"pixels", std::uint64_t{cam.width} * cam.height}};
    if (leaf_only) {
      auto leaf = capture(room, *leaf_only, cam);
      if (!leaf) return Error{where + " without LoD: " + leaf.message()};
      Json w;
      w["resident"] = leaf->resident;
      w["settle"] = settle_json(leaf->settle);
      w["hs_vs_sent"] = Json{{"differing_pixels", leaf->hs_vs_sent_differing},
                             {"pixels", std::uint64_t{cam.width} * cam.height}};
      if (auto st = add_fidelity_chain(room, cam, leaf->hs, leaf->sent.cover, "", w); !st)
        return Error{where + " without LoD: " + st.message()};
      c["without_lod"] = std::move(w);
    }
    cameras.push_back(std::move(c));
  }
  room.timing.phases["fidelity_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  Json out;
  out["budget"] = o.budget;
  out["cameras"] = std::move(cameras);
  out["stream"] = stream_json(*stream->session);
  return out;
}

}  // namespace gauss::eval_app
