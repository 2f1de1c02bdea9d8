#include "gauss/net/session_host.h"

#include <cstdio>
#include <optional>
#include <utility>

namespace gauss::net {

Expected<std::unique_ptr<SessionHost>> SessionHost::start(SessionHostConfig config, CodecParams params) {
  if (auto s = validate_codec_params(params); !s) return Error{"SessionHost: " + s.message()};
  // Over the network the transport proves the token (CPace, auth.h) and the Hellos
  // it passes on carry none, so a token is checked there and only there.
  if (!config.session.access_token.empty()) {
    if (config.net.access_token.empty()) config.net.access_token = config.session.access_token;
    if (config.net.access_token != config.session.access_token)
      return Error{"SessionHost: the session's and the transport's access tokens differ"};
    config.session.access_token.clear();
  }
  auto net = NetHost::start(config.net);
  if (!net) return net.error();
  return std::unique_ptr<SessionHost>(new SessionHost(std::move(config), params, std::move(net).value()));
}

SessionHost::SessionHost(SessionHostConfig config, CodecParams params, std::unique_ptr<NetHost> net)
    : config_(std::move(config)), params_(params), net_(std::move(net)), pool_(config_.tick_threads) {
  // Every session has the same eligibility rule, so one hierarchy serves them all: built and
  // updated once per epoch, by whichever session ticks first, instead of once per client.
  if (config_.session.lod && !config_.session.shared_lod)
    config_.session.shared_lod = std::make_shared<LodEpochHierarchy>(params_.sh_degree, *config_.session.lod);
  config_.session.lod_in_background = config_.lod_in_background && config_.session.lod;
  // So does the eligibility filter's verdict.
  if (config_.session.eligibility && !config_.session.shared_eligible)
    config_.session.shared_eligible = std::make_shared<SharedEligibleSet>(*config_.session.eligibility);
  // The selectors' per-Gaussian terms depend on the scene alone: computed once per epoch.
  if (!config_.session.shared_selector_terms) config_.session.shared_selector_terms = std::make_shared<SelectorTerms>();
}

void SessionHost::log(const std::string& line) {
  if (config_.net.log) config_.net.log(line);
  else std::fprintf(stderr, "[gauss-net host] %s\n", line.c_str());
}

void SessionHost::send_all(std::uint32_t client, const std::vector<wire::Message>& out) {
  for (const auto& m : out) {
    if (auto s = net_->send(client, m); !s) {
      ++stats_.send_errors;
      stats_.last_error = s.message();
      log("client " + std::to_string(client) + ": cannot send " + msg::to_string(wire::type_of(m)) + ": " + s.message());
    }
  }
}

bool SessionHost::lod_busy() const {
  // Without a session nobody waits: the scene may move on, and the next update catches up
  // with every epoch since through the change log.
  if (!config_.session.lod_in_background) return false;
  const LodEpochHierarchy& lod = *config_.session.shared_lod;
  return lod.reading_scene() || (!sessions_.empty() && lod.busy());
}

void SessionHost::advance_lod(const SceneStore& scene) {
  if (!config_.session.lod_in_background || scene.in_epoch() || to_underlying(scene.epoch()) == 0) return;
  // The hierarchy applies the eligibility rule itself, to the changed Gaussians alone where
  // it can: a filter over the whole scene here cost this thread 25-38 ms an epoch at 1M.
  const auto& rule = config_.session.eligibility;
  LodEpochHierarchy& lod = *config_.session.shared_lod;
  // The worker copies what it needs from the scene itself: the loop holds the next epoch
  // back meanwhile (lod_busy()), and this thread goes on serving.
  if (auto p = lod.update_in_background(scene, rule ? &*rule : nullptr, /*read_on_worker=*/true); !p) {
    ++stats_.lod_failures;
    stats_.last_error = p.message();
    log(p.message());
  }
  // Taken up: a build, or an update long enough that its clients noticed, is said.
  if (const std::uint64_t updates = lod.updates(); updates != lod_updates_seen_) {
    lod_updates_seen_ = updates;
    const auto last = lod.last_update();
    if (last && (last->built || last->seconds >= 1.0)) {
      char line[200];
      std::snprintf(line, sizeof line, "LoD: hierarchy for epoch %llu %s in %.2f s (%zu leaves, %zu interior nodes)",
                    static_cast<unsigned long long>(to_underlying(last->epoch)), last->built ? "built" : "updated",
                    last->seconds, last->leaves, last->interior);
      log(line);
    }
  }
}

void SessionHost::pump(const SceneStore& scene, double now) {
  // The hierarchy's update for a new epoch starts before anything else (with no client yet,
  // too: the first one finds it built), and a finished one is taken up again right before the
  // ticks, so a small scene's update is read in the pump that started it.
  advance_lod(scene);
  for (auto& e : net_->poll()) {
    switch (e.kind) {
      case HostEventKind::Connected: {
        auto [it, fresh] = sessions_.try_emplace(e.client, e.client, net_->session_id(), params_, config_.session);
        if (fresh) ++stats_.sessions_opened;
        client_names_[e.client] = e.hello.client_name;
        send_all(e.client, it->second.on_message(wire::Message{e.hello}, scene, now));
        if (config_.on_session_opened) config_.on_session_opened(e.client, e.hello.client_name, it->second);
        break;
      }
      case HostEventKind::Message: {
        auto it = sessions_.find(e.client);
        if (it == sessions_.end()) break;  // closed meanwhile: nothing to answer
        send_all(e.client, it->second.on_message(e.message, scene, now));
        break;
      }
      case HostEventKind::Disconnected:
        // A client gone mid-batch costs nothing more: its session and queues go.
        if (auto it = sessions_.find(e.client); it != sessions_.end()) close(it);
        break;
    }
  }
  // The sessions due this pump tick in parallel (each reads the scene and writes only
  // itself); their messages go out afterwards, in client order, from this thread.
  std::vector<std::pair<std::uint32_t, HostSession*>> due;
  for (auto& [client, session] : sessions_) {
    if (session.closed()) continue;
    if (net_->pending_bytes(client) > config_.max_pending_bytes) {
      ++stats_.held_back;
      continue;
    }
    due.emplace_back(client, &session);
  }
  advance_lod(scene);
  std::vector<std::optional<Expected<std::vector<wire::Message>>>> out(due.size());
  pool_.parallel_for(due.size(), [&](std::size_t i) { out[i] = due[i].second->tick(scene, now); });
  for (std::size_t i = 0; i < due.size(); ++i) {
    for (const std::string& line : due[i].second->take_notices()) log(line);
    Expected<std::vector<wire::Message>>& r = *out[i];
    if (!r) {
      ++stats_.tick_errors;
      stats_.last_error = r.message();
      log(r.message());
      continue;
    }
    send_all(due[i].first, r.value());
  }
}

void SessionHost::close(std::map<std::uint32_t, HostSession>::iterator it) {
  const std::uint32_t client = it->first;
  if (config_.on_session_closed) config_.on_session_closed(client, client_names_[client], it->second);
  client_names_.erase(client);
  sessions_.erase(it);
  ++stats_.sessions_closed;
}

void SessionHost::close_all() {
  while (!sessions_.empty()) {
    const std::uint32_t client = sessions_.begin()->first;
    close(sessions_.begin());
    net_->disconnect(client);
  }
}

HostSession* SessionHost::session(std::uint32_t client) {
  auto it = sessions_.find(client);
  return it == sessions_.end() ? nullptr : &it->second;
}

std::vector<std::uint32_t> SessionHost::clients() const {
  std::vector<std::uint32_t> ids;
  for (const auto& [id, s] : sessions_) ids.push_back(id);
  return ids;
}

}  // namespace gauss::net
