// Stage latencies from the event logs (virtual seconds), on the real client path.
//   model edits: a room produced live (or a snapshot folder replayed), one epoch per
//     --epoch-period while the client watches camera 0: per epoch, available (the host's scene committed it) -> sent ->
//     received -> published (in slots) -> first frame rendered with it;
//   queries: see query_latency(), called by the semantic runs.
#include <algorithm>
#include <chrono>

#include "measurements.h"

namespace gauss::eval_app {

namespace {

const StageEvent* first_batch(const EventLog& log, Epoch e, BatchStage stage) {
  for (const StageEvent& ev : log.events())
    if (!ev.is_query && ev.epoch == to_underlying(e) && ev.stage == static_cast<std::uint8_t>(stage)) return &ev;
  return nullptr;
}

Json stats_of(std::vector<double> v) {
  if (v.empty()) return nullptr;
  std::sort(v.begin(), v.end());
  return Json{{"p50", percentile_of(v, 0.5)}, {"max", v.back()}, {"n", v.size()}};
}

}  // namespace

Json query_latency(EvalSession& session, std::uint32_t query_id, double sent_at) {
  EventLog client_log = session.client().with_state([](const ClientState& s) { return s.events(); });
  auto at = [&](const EventLog& log, QueryStage stage) -> Json {
    for (const StageEvent& ev : log.events())
      if (ev.is_query && ev.query == query_id && ev.stage == static_cast<std::uint8_t>(stage)) return ev.t - sent_at;
    return nullptr;
  };
  auto count = [&](const EventLog& log, QueryStage stage) -> Json {
    for (const StageEvent& ev : log.events())
      if (ev.is_query && ev.query == query_id && ev.stage == static_cast<std::uint8_t>(stage)) return ev.count;
    return nullptr;
  };
  return Json{{"resolved_s", at(session.host_events(), QueryStage::Resolved)},
              {"highlight_s", at(client_log, QueryStage::Highlight)},
              {"first_additional_s", at(client_log, QueryStage::FirstAdditional)},
              {"converged_s", at(client_log, QueryStage::Converged)},
              {"initial_residency", count(client_log, QueryStage::InitialResidency)},
              {"desired_residency", count(session.host_events(), QueryStage::DesiredResidency)}};
}

Expected<Json> measure_model_latency(Room& room) {
  const auto t0 = std::chrono::steady_clock::now();
  const Options& o = room.options;
  // The same scene, produced live (a room) or replayed (a snapshot folder): the first half
  // of its epochs before the client connects, the rest one per epoch period while it watches.
  auto feed = EpochFeed::open(room.scene, o);
  if (!feed) return feed.error();
  SceneStore store;
  const int before = std::max(1, feed->total() / 2);
  for (int e = 0; e < before; ++e)
    if (auto st = feed->produce(store); !st) return st.error();
  EvalSessionConfig cfg = session_config(o, o.budget, o.progressive ? PublishMode::Progressive : PublishMode::Immediate);
  auto session = EvalSession::create(room.context, store, room.scene.codec, cfg);
  if (!session) return session.error();
  const Camera& cam = room.scene.cameras.front();
  room.progress("model latency: first epochs");
  auto first = (*session)->settle(cam, o.settle_timeout_s, o.quiet_s);
  if (!first) return first.error();
  std::vector<std::pair<Epoch, double>> available;
  while (!feed->finished()) {
    room.progress("model latency: epoch " + std::to_string(feed->produced() + 1) + "/" + std::to_string(feed->total()));
    // Ticks up to now have run: the epoch is available from now on, to the next tick.
    if (auto st = (*session)->run_host_until((*session)->now()); !st) return st.error();
    if (auto st = feed->produce(store); !st) return st.error();
    available.emplace_back(store.epoch(), (*session)->now());
    const double until = (*session)->now() + o.epoch_period_s;
    while ((*session)->now() < until)
      if (auto f = (*session)->step(cam); !f) return f.error();
  }
  auto last = (*session)->settle(cam, o.settle_timeout_s, o.quiet_s);
  if (!last) return last.error();
  const EventLog client_log = (*session)->client().with_state([](const ClientState& s) { return s.events(); });
  const EventLog& host_log = (*session)->host_events();
  Json epochs = Json::array();
  std::vector<double> sent, received, published, visible;
  for (const auto& [e, t] : available) {
    const StageEvent* s = first_batch(host_log, e, BatchStage::Sent);
    const StageEvent* r = first_batch(client_log, e, BatchStage::Received);
    const StageEvent* p = first_batch(client_log, e, BatchStage::Published);
    const StageEvent* f = first_batch(client_log, e, BatchStage::FirstFrame);
    auto rel = [&](const StageEvent* ev) -> Json { return ev ? Json(ev->t - t) : Json(nullptr); };
    if (s) sent.push_back(s->t - t);
    if (r) received.push_back(r->t - t);
    if (p) published.push_back(p->t - t);
    if (f) visible.push_back(f->t - t);
    epochs.push_back(Json{{"epoch", to_underlying(e)},
                          {"available_t", t},
                          {"edits", s ? Json(s->count) : Json(nullptr)},
                          {"sent_s", rel(s)},
                          {"received_s", rel(r)},
                          {"published_s", rel(p)},
                          {"visible_s", rel(f)}});
  }
  room.timing.phases["model_latency_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return Json{{"epoch_period_s", o.epoch_period_s},
              {"epochs_before", before},
              {"settle_first", settle_json(*first)},
              {"settle_last", settle_json(*last)},
              {"available_to_sent_s", stats_of(sent)},
              {"available_to_received_s", stats_of(received)},
              {"available_to_published_s", stats_of(published)},
              {"available_to_visible_s", stats_of(visible)},
              {"epochs", std::move(epochs)},
              {"stream", stream_json(**session)}};
}

}  // namespace gauss::eval_app
