#pragma once
// ClientStateSink: connects a NetClient's network thread to an engine ClientState.
// Every host message goes to ClientState::on_message (CPU-side state only, under
// ClientState's own mutex); its queued acks, poses and queries go back out. The
// display loop keeps calling ClientState::frame() on its own thread, through
// with_state(), which also makes ClientState's unlocked inspection calls (check(),
// published_checksum(), desired()) safe against the network thread.
#include <atomic>
#include <cstdint>
#include <functional>
#include <mutex>
#include <optional>
#include <utility>
#include <string>

#include "gauss/engine/client_state.h"
#include "gauss/net/client.h"

namespace gauss::net {

class ClientStateSink final : public ClientSink {
 public:
  // `clock` gives the client time in seconds (the clock frame() is called with).
  ClientStateSink(ClientState& state, std::function<double()> clock) : state_(state), clock_(std::move(clock)) {}

  void on_welcome(const msg::Welcome& welcome) override {
    client_id_ = welcome.client_id;
    apply(wire::Message{welcome});
  }
  void on_message(wire::Message&& message) override { apply(message); }
  void on_refused(const msg::Refuse& refuse) override {
    refused_ = true;
    apply(wire::Message{refuse});
  }
  void on_disconnected(const std::string&) override {
    std::lock_guard lock(mu_);
    state_.on_disconnect();
  }
  std::vector<wire::Message> take_outgoing() override {
    std::lock_guard lock(mu_);
    return state_.take_outgoing();
  }

  // Runs f(ClientState&) while the network thread is kept out.
  template <class F>
  decltype(auto) with_state(F&& f) {
    std::lock_guard lock(mu_);
    return f(state_);
  }

  // As with_state when the lock is free now; nothing (f not run) while another thread holds
  // it: for a display loop that must not wait (a publication step holds it for its length).
  template <class F>
  auto try_with_state(F&& f) -> std::optional<decltype(f(std::declval<ClientState&>()))> {
    std::unique_lock lock(mu_, std::try_to_lock);
    if (!lock.owns_lock()) return std::nullopt;
    return f(state_);
  }

  bool refused() const noexcept { return refused_; }
  // The host's id for the current (latest) connection; 0 before the first Welcome.
  std::uint32_t client_id() const noexcept { return client_id_; }
  // Messages ClientState rejected (it keeps the reasons in its stats).
  std::uint64_t rejected() const noexcept { return rejected_; }

 private:
  void apply(const wire::Message& m) {
    std::lock_guard lock(mu_);
    if (!state_.on_message(m, clock_())) ++rejected_;
  }

  std::mutex mu_;
  ClientState& state_;
  std::function<double()> clock_;
  std::atomic<bool> refused_{false};
  std::atomic<std::uint32_t> client_id_{0};
  std::atomic<std::uint64_t> rejected_{0};
};

}  // namespace gauss::net
