#pragma once
// What every gauss-eval measurement shares: the host's two renderers (the full float
// scene, PC; and the set it sent, in the client's slots), coverage masks, the metrics as
// JSON, and one "settle the client at a view and capture it" step.
//
// Coverage (which pixels an image "covers", for PC-HS): a pixel is covered when the
// splats' accumulated opacity there is at least 0.5, or a surface chunk is drawn under
// it. Measured by rendering the view twice, over a black and over a white background:
// the blend writes C + T * background, so the two differ by 255 T; covered = every
// channel differs by less than 128. The renderer writes alpha 255 everywhere, so alpha
// cannot say it.
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "eval_scene.h"
#include "eval_session.h"
#include "gauss/engine/image_io.h"
#include "gauss/eval/image_metrics.h"
#include "gauss/render/splat_renderer.h"

namespace gauss::eval_app {

using Json = nlohmann::ordered_json;

// The host's render of the full float scene (PC): every appearance Gaussian in the
// store's order, the scene's surface chunks. Errors: sizes, capacity, an upload.
Expected<std::unique_ptr<render::SplatRenderer>> make_full_renderer(vk::Context& context, const EvalScene& scene,
                                                                    std::uint32_t width, std::uint32_t height);
// The host's renderer of the set it sent one client: M slots and the stream's SH degree,
// like the client's (EvalSession::load_sent_set fills it).
Expected<std::unique_ptr<render::SplatRenderer>> make_sent_renderer(vk::Context& context, const EvalScene& scene,
                                                                    std::uint32_t budget, std::uint32_t width,
                                                                    std::uint32_t height);

// Loads a client's published set into `renderer` as the client holds it: `record_of(id)`
// at each occupied slot of `held` (sorted by slot), every other slot cleared, so equal
// depths blend in the client's slot order. Errors: the first `record_of` error (an id the
// host did not send), a slot beyond the renderer, an upload failure.
Status write_at_slots(render::SplatRenderer& renderer, std::span<const std::pair<std::uint32_t, GaussianId>> held,
                      const std::function<Expected<Gaussian>(GaussianId)>& record_of);

struct CoveredImage {
  ImageRGBA8 image;  // over black (the client's background)
  eval::Mask cover;
};
// Renders `camera` with `renderer`'s current slots over black and over white.
Expected<CoveredImage> render_covered(render::SplatRenderer& renderer, const Camera& camera);

eval::ImageView view_of(const ImageRGBA8& image);
eval::Mask valid_depth_mask(const GroundTruthImage& gt);
// Valid GT depth and an object id among `targets` (sorted).
eval::Mask object_mask(const GroundTruthImage& gt, std::span<const ObjectId> targets);
eval::Mask mask_and(const eval::Mask& a, const eval::Mask& b);
std::uint64_t count(const eval::Mask& m);
// The share of the image a mask covers (0 for an empty mask).
double fraction(const eval::Mask& m);
// Pixels whose RGBA bytes differ at all.
std::uint64_t differing_pixels(const ImageRGBA8& a, const ImageRGBA8& b);

// {"psnr_db", "ssim", "flip", "pixels"} of `test` against `reference` over `mask`; PSNR
// "inf" for identical pixels; {"error": why} when the metric refuses (no pixel in the
// mask, sizes).
Json scores(const ImageRGBA8& reference, const ImageRGBA8& test, const eval::Mask& mask);
// Percentiles p50 / p95 / p99 and the count, of a sample (frame times).
Json percentiles(const std::vector<double>& v);
// The p-quantile of a sample (linear between order statistics; 0 when empty).
double percentile_of(const std::vector<double>& v, double p);
// A double as JSON: the number, or "inf" / "-inf" / "nan".
Json number(double v);

// The client settled at a view, captured.
struct ClientCapture {
  SettleResult settle;
  ImageRGBA8 hs;                   // the client's frame after convergence
  CoveredImage sent;               // the host's render of the set it sent (client slot order)
  std::uint64_t hs_vs_sent_differing{0};
  std::uint32_t resident{0};
  std::uint64_t desired{0};
};
// Settles the session at `camera` (see EvalSession::settle), reads the client's frame and
// renders the host's sent set with `sent` (make_sent_renderer at the session's M). Errors:
// a frame, readback or render failure (a view that does not converge is not an error:
// settle.converged says so).
// `on_frame` (may be empty) sees every frame of the settle.
Expected<ClientCapture> capture_client(EvalSession& session, render::SplatRenderer& sent, const Camera& camera,
                                       const Options& options,
                                       const std::function<void(const client::DisplayFrameStats&)>& on_frame = {});

// The JSON of a settle (deterministic: virtual times and counts only).
Json settle_json(const SettleResult& s);
// The session's stream figures (virtual time, messages, bytes, batches, edits, rejections).
Json stream_json(EvalSession& session);
// A camera as JSON (intrinsics and the row-major world_to_camera, as camera files hold it).
Json camera_json(const Camera& c);

}  // namespace gauss::eval_app
