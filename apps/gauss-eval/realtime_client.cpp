#include "realtime_client.h"

#include <algorithm>
#include <chrono>
#include <span>
#include <thread>

#include "eval_scene.h"
#include "gauss/eval/image_metrics.h"
#include "seconds_since.h"

namespace gauss::eval_app {

namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

Expected<std::unique_ptr<RealtimeClient>> RealtimeClient::connect(vk::Context& context,
                                                                  const RealtimeClientConfig& c) {
  client::ClientRuntimeConfig rc;
  rc.state.capacity = c.budget;
  rc.state.name = c.name;
  rc.state.publisher.mode = c.mode;
  rc.state.publisher.display_period_s = 1.0 / c.display_hz;
  rc.max_width = c.width;
  rc.max_height = c.height;
  rc.highlight_query = false;  // measured, not tinted (as the deterministic runs)
  rc.publication_thread = c.publication_thread;
  auto rt = client::ClientRuntime::create(context, rc);  // the real clock: steady time
  if (!rt) return Error{"the realtime client: " + rt.message()};
  net::NetClientConfig net;
  net.server = net::Endpoint{"127.0.0.1", c.port};
  net.log = [](const std::string&) {};  // its state changes are judged by settle(), not printed
  if (auto st = (*rt)->connect(net); !st) return Error{"the realtime client: connecting: " + st.message()};
  return std::unique_ptr<RealtimeClient>(new RealtimeClient(std::move(*rt), c.display_hz));
}

Expected<client::DisplayFrameStats> RealtimeClient::paced_frame(std::span<const Camera> views, Clock::time_point& next) {
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / display_hz_));
  std::this_thread::sleep_until(next);
  next = std::max(next + period, Clock::now());  // a late frame is not made up
  auto f = runtime_->frame(views);
  if (!f) return Error{"the realtime client's frame: " + f.message()};
  return f;
}

Status RealtimeClient::wait_for_query(const Camera& view, double timeout_s) {
  const auto t0 = Clock::now();
  auto next = t0;
  while (apps::seconds_since(t0) <= timeout_s) {
    if (runtime_->with_state([](const ClientState& s) { return !s.query_targets().empty(); })) return Ok{};
    if (runtime_->connection().status == net::ClientStatus::Refused)
      return Error{"gauss-host refused the client: " + runtime_->connection().counters.last_rejection};
    auto f = paced_frame(std::span<const Camera>(&view, 1), next);
    if (!f) return f.error();
  }
  return Error{"the host's resolution of the query did not arrive within " + std::to_string(timeout_s) + " s"};
}

Expected<RealtimeSettle> RealtimeClient::settle(const Camera& view, double timeout_s, double quiet_s) {
  RealtimeSettle r;
  const auto t0 = Clock::now();
  auto next = t0;
  std::uint64_t last_messages = ~std::uint64_t{0};
  double quiet_since = -1.0;
  while (apps::seconds_since(t0) <= timeout_s) {
    auto f = paced_frame(std::span<const Camera>(&view, 1), next);
    if (!f) return f.error();
    const double t = apps::seconds_since(t0);
    ++r.frames;
    r.slot_writes += f->publish.slot_writes();
    r.frame_cpu_ms.push_back(f->cpu_ms);
    const client::ConnectionInfo conn = runtime_->connection();
    if (conn.status == net::ClientStatus::Refused)
      return Error{"gauss-host refused the client: " + conn.counters.last_rejection};
    const bool welcomed = runtime_->with_state([](const ClientState& s) { return s.welcomed(); });
    // Quiet: in the stream, nothing left to publish, and no host message since the last frame.
    const bool quiet = welcomed && conn.status == net::ClientStatus::Connected && f->pending == 0 &&
                       f->desired > 0 && f->publish.slot_writes() == 0 &&
                       conn.counters.messages_received == last_messages;
    last_messages = conn.counters.messages_received;
    if (!quiet) {
      quiet_since = -1.0;
      continue;
    }
    if (quiet_since < 0.0) quiet_since = t;
    if (t - quiet_since >= quiet_s) {
      r.converged = true;
      r.converged_s = quiet_since;
      break;
    }
  }
  r.wall_s = apps::seconds_since(t0);
  return r;
}

Expected<RealtimeFlicker> RealtimeClient::flicker(const Camera& a, double window_s) {
  RealtimeFlicker r;
  const std::uint64_t messages_before = runtime_->connection().counters.messages_received;
  const auto t0 = Clock::now();
  auto next = t0;
  eval::FrameChange change;
  while (apps::seconds_since(t0) < window_s) {
    const Camera views[2] = {swayed(a, apps::seconds_since(t0)), a};
    auto f = paced_frame(views, next);
    if (!f) return f.error();
    ++r.frames;
    r.slot_writes += f->publish.slot_writes();
    r.membership_changes += f->publish.inserted + f->publish.removed + 2ull * f->publish.replaced;
    r.frame_cpu_ms.push_back(f->cpu_ms);
    auto img = runtime_->renderer().read_image(1);
    if (!img) return Error{"the realtime client's readback: " + img.message()};
    if (auto st = change.add({img->width, img->height, img->pixels}); !st) return st.error();
  }
  r.window_s = apps::seconds_since(t0);
  r.mean_abs_change = change.mean();
  r.max_abs_change = change.max();
  r.host_messages = runtime_->connection().counters.messages_received - messages_before;
  return r;
}

std::pair<std::uint32_t, double> RealtimeClient::send_query(const msg::Query& query) {
  const double at = runtime_->now();
  return {runtime_->send_query(query), at};
}

RealtimeQueryStages RealtimeClient::query_stages(std::uint32_t id, double sent_at) {
  const EventLog log = runtime_->with_state([](const ClientState& s) { return s.events(); });
  RealtimeQueryStages r;
  for (const StageEvent& ev : log.events()) {
    if (!ev.is_query || ev.query != id) continue;
    const auto first = [&](std::optional<double>& slot) {
      if (!slot) slot = ev.t - sent_at;
    };
    switch (static_cast<QueryStage>(ev.stage)) {
      case QueryStage::Target: first(r.targets_s); break;
      case QueryStage::Highlight: first(r.highlight_s); break;
      case QueryStage::FirstAdditional: first(r.first_additional_s); break;
      case QueryStage::Converged: first(r.converged_s); break;
      case QueryStage::InitialResidency:
        if (!r.initial_residency) r.initial_residency = ev.count;
        break;
      default: break;
    }
  }
  return r;
}

Expected<RealtimeCapture> RealtimeClient::capture() {
  RealtimeCapture c;
  if (auto st = runtime_->wait_frames(); !st) return st.error();
  auto hs = runtime_->renderer().read_image();
  if (!hs) return hs.error();
  c.hs = std::move(*hs);
  runtime_->with_state([&](const ClientState& s) {
    const SlotTable& slots = s.slots();
    for (std::uint32_t k = 0; k < slots.capacity(); ++k) {
      GaussianId id{0};
      if (!slots.occupant(SlotIndex{k}, id)) continue;
      c.slots.emplace_back(k, id);
      c.slot_objects.push_back(slots.records()[k].object);
    }
    c.query_target_gaussians = s.query_target_gaussians();
    c.published_checksum = s.published_checksum();
    c.resident = slots.size();
    c.desired = s.desired().desired_count();
    return 0;
  });
  return c;
}

}  // namespace gauss::eval_app
