#include "measure.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "gauss/engine/camera_io.h"
#include "percentile.h"

namespace gauss::eval_app {

Expected<std::unique_ptr<render::SplatRenderer>> make_full_renderer(vk::Context& context, const EvalScene& scene,
                                                                    std::uint32_t width, std::uint32_t height) {
  const std::vector<Gaussian> all = appearance_gaussians(*scene.store);
  auto r = render::SplatRenderer::create(context, {.capacity = static_cast<std::uint32_t>(std::max<std::size_t>(1, all.size())),
                                                   .sh_degree = scene.store->sh_degree(),
                                                   .max_width = width,
                                                   .max_height = height});
  if (!r) return Error{"the host's full-scene renderer: " + r.message()};
  if (auto st = (*r)->write_slots(0, all); !st) return Error{"the host's full-scene renderer: " + st.message()};
  for (const SurfaceChunk& chunk : scene.store->surface_chunks())
    if (auto st = (*r)->set_mesh_chunk(chunk.chunk_id, chunk.mesh); !st) return st.error();
  return r;
}

Expected<std::unique_ptr<render::SplatRenderer>> make_sent_renderer(vk::Context& context, const EvalScene& scene,
                                                                    std::uint32_t budget, std::uint32_t width,
                                                                    std::uint32_t height) {
  auto r = render::SplatRenderer::create(
      context, {.capacity = budget, .sh_degree = scene.codec.sh_degree, .max_width = width, .max_height = height});
  if (!r) return Error{"the host's sent-set renderer: " + r.message()};
  return r;
}

Status write_at_slots(render::SplatRenderer& renderer, std::span<const std::pair<std::uint32_t, GaussianId>> held,
                      const std::function<Expected<Gaussian>(GaussianId)>& record_of) {
  // Runs of occupied slots are written with one call each, the gaps between them cleared.
  std::vector<Gaussian> run;
  std::uint32_t run_first = 0, next_clear = 0;
  auto flush = [&]() -> Status {
    if (run.empty()) return Ok{};
    if (run_first > next_clear)
      if (auto st = renderer.clear_slots(next_clear, run_first - next_clear); !st) return st;
    if (auto st = renderer.write_slots(run_first, run); !st) return st;
    next_clear = run_first + static_cast<std::uint32_t>(run.size());
    run.clear();
    return Ok{};
  };
  for (const auto& [slot, id] : held) {
    auto g = record_of(id);
    if (!g) return g.error();
    if (!run.empty() && slot != run_first + run.size())
      if (auto st = flush(); !st) return st;
    if (run.empty()) run_first = slot;
    run.push_back(std::move(*g));
  }
  if (auto st = flush(); !st) return st;
  if (renderer.capacity() > next_clear)
    if (auto st = renderer.clear_slots(next_clear, renderer.capacity() - next_clear); !st) return st;
  return Ok{};
}

Expected<CoveredImage> render_covered(render::SplatRenderer& renderer, const Camera& camera) {
  CoveredImage out;
  render::SplatRenderOptions black;  // the client's options: default background black
  render::SplatRenderOptions white = black;
  white.clear_colour = glm::vec3(1.0f);
  if (auto st = renderer.render(camera, white); !st) return st.error();
  auto over_white = renderer.read_image();
  if (!over_white) return over_white.error();
  if (auto st = renderer.render(camera, black); !st) return st.error();
  auto over_black = renderer.read_image();
  if (!over_black) return over_black.error();
  out.image = std::move(*over_black);
  const std::size_t n = std::size_t(out.image.width) * out.image.height;
  out.cover.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i) {
    int d = 0;
    for (int c = 0; c < 3; ++c) d = std::max(d, std::abs(int(over_white->pixels[i * 4 + c]) - int(out.image.pixels[i * 4 + c])));
    out.cover[i] = d < 128 ? 1 : 0;
  }
  return out;
}

eval::ImageView view_of(const ImageRGBA8& image) { return {image.width, image.height, image.pixels}; }

eval::Mask valid_depth_mask(const GroundTruthImage& gt) {
  eval::Mask m(gt.depth.size());
  for (std::size_t i = 0; i < m.size(); ++i) m[i] = gt.depth[i] > 0.0f ? 1 : 0;
  return m;
}

eval::Mask object_mask(const GroundTruthImage& gt, std::span<const ObjectId> targets) {
  eval::Mask m(gt.depth.size());
  for (std::size_t i = 0; i < m.size(); ++i)
    m[i] = gt.depth[i] > 0.0f && std::binary_search(targets.begin(), targets.end(), gt.object[i]) ? 1 : 0;
  return m;
}

eval::Mask mask_and(const eval::Mask& a, const eval::Mask& b) {
  eval::Mask m(std::min(a.size(), b.size()));
  for (std::size_t i = 0; i < m.size(); ++i) m[i] = a[i] && b[i] ? 1 : 0;
  return m;
}

std::uint64_t count(const eval::Mask& m) {
  return static_cast<std::uint64_t>(std::count_if(m.begin(), m.end(), [](std::uint8_t v) { return v != 0; }));
}

double fraction(const eval::Mask& m) { return m.empty() ? 0.0 : double(count(m)) / double(m.size()); }

std::uint64_t differing_pixels(const ImageRGBA8& a, const ImageRGBA8& b) {
  if (a.width != b.width || a.height != b.height || a.pixels.size() != b.pixels.size())
    return std::uint64_t{a.width} * a.height;
  std::uint64_t n = 0;
  for (std::size_t i = 0; i + 3 < a.pixels.size(); i += 4)
    n += !std::equal(a.pixels.begin() + i, a.pixels.begin() + i + 4, b.pixels.begin() + i);
  return n;
}

double percentile_of(const std::vector<double>& v, double p) { return apps::percentile(v, p); }

Json percentiles(const std::vector<double>& v) {
  return Json{{"p50", apps::percentile(v, 0.5)},
              {"p95", apps::percentile(v, 0.95)},
              {"p99", apps::percentile(v, 0.99)},
              {"n", v.size()}};
}

Json number(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

Json scores(const ImageRGBA8& reference, const ImageRGBA8& test, const eval::Mask& mask) {
  if (count(mask) == 0) return Json{{"error", "no pixel in the mask"}, {"pixels", 0}};
  auto s = eval::compare(view_of(reference), view_of(test), mask);
  if (!s) return Json{{"error", s.message()}};
  return Json{{"psnr_db", number(s->psnr_db)}, {"ssim", number(s->ssim)}, {"flip", number(s->flip)},
              {"pixels", s->pixels}};
}

Expected<ClientCapture> capture_client(EvalSession& session, render::SplatRenderer& sent_renderer,
                                       const Camera& camera, const Options& o,
                                       const std::function<void(const client::DisplayFrameStats&)>& on_frame) {
  ClientCapture c;
  auto s = session.settle(camera, o.settle_timeout_s, o.quiet_s, on_frame);
  if (!s) return s.error();
  c.settle = std::move(*s);
  if (auto st = session.client().wait_frames(); !st) return st.error();
  auto hs = session.client().renderer().read_image();
  if (!hs) return hs.error();
  c.hs = std::move(*hs);
  c.resident = session.client().with_state([](const ClientState& st) { return st.slots().size(); });
  c.desired = session.client().with_state([](const ClientState& st) { return st.desired().desired_count(); });
  if (auto st = session.load_sent_set(sent_renderer); !st) return st.error();
  auto sent = render_covered(sent_renderer, camera);
  if (!sent) return sent.error();
  c.sent = std::move(*sent);
  c.hs_vs_sent_differing = differing_pixels(c.hs, c.sent.image);
  return c;
}

Json settle_json(const SettleResult& s) {
  return Json{{"converged", s.converged},
              {"start_s", s.start_s},
              {"in_sync_s", s.in_sync_s},
              {"converged_s", s.converged_s},
              {"frames", s.frames},
              {"slot_writes", s.slot_writes}};
}

Json stream_json(EvalSession& session) {
  const HostSessionStats& hs = session.host().stats();
  const auto client_rejected =
      session.client().with_state([](const ClientState& s) { return s.stats().rejected_messages; });
  return Json{{"virtual_s", session.now()},
              {"messages_down", session.messages_down()},
              {"bytes_down", session.bytes_down()},
              {"batches", hs.batches_sent},
              {"edits", hs.edits_sent},
              {"host_rejected_messages", hs.rejected_messages},
              {"client_rejected_messages", client_rejected}};
}

Json camera_json(const Camera& c) {
  auto text = camera_to_json(c);
  if (!text) return Json{{"error", text.message()}};
  return Json::parse(*text);
}

}  // namespace gauss::eval_app
