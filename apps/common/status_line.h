#pragma once
// StatusLine and with_elapsed_status: the one status line on stderr that every program in
// apps/ shows for work that takes longer than about a second (gauss_cli.h includes this; a
// file that needs nothing of CLI11 includes this alone).
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <future>
#include <string>
#include <utility>

namespace gauss::apps {

// One status line on stderr for long work. On a terminal it rewrites itself in place
// (\r, at most 10 times a second); otherwise (a log, a pipe, CI) it stays silent and
// done() prints its text, if any, as one final line, so logs get one line, not hundreds.
class StatusLine {
 public:
  StatusLine() : live_(isatty(fileno(stderr)) == 1) {}
  ~StatusLine() {
    if (live_ && shown_) done({});
  }
  StatusLine(const StatusLine&) = delete;
  StatusLine& operator=(const StatusLine&) = delete;

  bool live() const noexcept { return live_; }

  // Shows `text` (terminal only; throttled unless `force`).
  void update(const std::string& text, bool force = false) {
    if (!live_) return;
    const auto now = std::chrono::steady_clock::now();
    if (!force && shown_ && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    shown_ = true;
    std::fprintf(stderr, "\r%s\033[K", text.c_str());
    std::fflush(stderr);
  }

  // Ends the line: on a terminal `text` replaces it (an empty text clears it); elsewhere
  // a non-empty `text` is printed as one line.
  void done(const std::string& text) {
    if (live_) {
      std::fprintf(stderr, "\r%s\033[K%s", text.c_str(), text.empty() ? "" : "\n");
    } else if (!text.empty()) {
      std::fprintf(stderr, "%s\n", text.c_str());
    }
    std::fflush(stderr);
    shown_ = false;
  }

 private:
  bool live_;
  bool shown_{false};
  std::chrono::steady_clock::time_point last_{};
};

// Runs `work` (one long call that reports no progress of its own) and, on a terminal,
// shows "<label> 12.3 s" counting up meanwhile; the line is cleared when it returns.
// Without a terminal `work` simply runs on the calling thread.
template <class F>
auto with_elapsed_status(const std::string& label, F&& work) {
  StatusLine line;
  if (!line.live()) return work();
  auto result = std::async(std::launch::async, std::forward<F>(work));
  const auto t0 = std::chrono::steady_clock::now();
  while (result.wait_for(std::chrono::milliseconds(100)) != std::future_status::ready) {
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    char text[64];
    std::snprintf(text, sizeof text, " %.1f s", s);
    line.update(label + text);
  }
  line.done({});
  return result.get();
}

}  // namespace gauss::apps
