// Runs the peer renderer for gauss-bench render --peer (see bench_peer.h).
#include "bench_peer.h"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>
#include <vector>

extern char** environ;

namespace gauss::bench {

namespace fs = std::filesystem;

namespace {

// The last `n` non-empty lines of `text`, joined by " / " (the reason a run failed is there).
std::string last_lines(const std::string& text, std::size_t n) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) lines.push_back(line);
  std::string out;
  for (std::size_t i = lines.size() > n ? lines.size() - n : 0; i < lines.size(); ++i)
    out += (out.empty() ? "" : " / ") + lines[i];
  return out.empty() ? "(no output)" : out;
}

std::string read_text(const fs::path& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

}  // namespace

Status check_peer_binary(const fs::path& binary) {
  std::error_code ec;
  if (!fs::is_regular_file(binary, ec)) return Error{"the peer " + binary.string() + " is not a file"};
  if (::access(binary.c_str(), X_OK) != 0) {
    return Error{"the peer " + binary.string() + " cannot be executed: " + std::strerror(errno)};
  }
  return Ok{};
}

Expected<double> run_peer(const PeerRunInfo& info) {
  char fov[32];
  std::snprintf(fov, sizeof fov, "%.6f", info.fov_deg);
  std::vector<std::string> args = {info.binary.string(),       info.scene.string(), "--width",
                                   std::to_string(info.width), "--height",          std::to_string(info.height),
                                   "--fov",                    fov,                 "--warmup",
                                   std::to_string(info.warmup), "--frames",         std::to_string(info.frames)};
  std::string command;
  for (const auto& a : args) command += (command.empty() ? "" : " ") + a;
  const fs::path log = fs::path(info.scene).replace_extension(".peer.log");
  const int log_fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (log_fd < 0) return Error{"cannot write the peer's log " + log.string() + ": " + std::strerror(errno)};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  // posix_spawn, not fork: this process may hold gigabytes of scene and a Vulkan device's
  // threads; glibc reports a failed exec (missing file, wrong format) as its return value.
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, log_fd, STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, log_fd, STDERR_FILENO);
  pid_t pid = 0;
  const int spawned = ::posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(log_fd);
  if (spawned != 0) return Error{"cannot start the peer " + info.binary.string() + ": " + std::strerror(spawned)};

  // Bounded wait; on timeout the peer (and only it, by its pid) is ended.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(info.timeout_s);
  int status = 0;
  bool timed_out = false;
  while (::waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, &status, 0);
      timed_out = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const std::string output = read_text(log);
  const std::string context = "`" + command + "`";
  if (timed_out) {
    return Error{context + " did not finish within " + std::to_string(info.timeout_s) + " s; last output: " +
                 last_lines(output, 3)};
  }
  if (WIFSIGNALED(status)) {
    return Error{context + " was killed by signal " + std::to_string(WTERMSIG(status)) + " (" +
                 strsignal(WTERMSIG(status)) + "); last output: " + last_lines(output, 3)};
  }
  if (WEXITSTATUS(status) != 0) {
    return Error{context + " exited with status " + std::to_string(WEXITSTATUS(status)) + ": " +
                 last_lines(output, 3)};
  }
  static const std::regex median_line(R"(median_wall_ms ([0-9]+(\.[0-9]*)?))");
  std::smatch m;
  if (!std::regex_search(output, m, median_line)) {
    return Error{context + " printed no 'median_wall_ms X' line (is it the 3dgs_bench.patch build?); last output: " +
                 last_lines(output, 3)};
  }
  std::error_code ec;
  fs::remove(log, ec);
  return std::stod(m[1].str());
}

double horizontal_fov_deg(std::uint32_t width, double fx) {
  return 2.0 * std::atan(0.5 * double(width) / fx) * 180.0 / 3.14159265358979323846;
}

void print_peer_summary(const std::vector<PeerRow>& rows, const fs::path& binary, int rounds, int frames) {
  std::printf("\nours / peer, median of %d alternating round(s) per size; wall ms per frame (peer: %s, %d warm-up + "
              "%d frames; ours: 1 warm-up + %d frames)\n",
              rounds, binary.string().c_str(), PeerRunInfo{}.warmup, frames, frames);
  std::printf("%-22s %9s %9s %9s\n", "size", "peer_ms", "ours_ms", "ours/peer");
  for (const PeerRow& r : rows) {
    char peer[16] = "-", ours[16] = "-", ratio[16] = "-";
    if (r.peer_ms > 0) std::snprintf(peer, sizeof peer, "%.2f", r.peer_ms);
    if (r.ours_ms > 0) std::snprintf(ours, sizeof ours, "%.2f", r.ours_ms);
    if (r.peer_ms > 0 && r.ours_ms > 0) std::snprintf(ratio, sizeof ratio, "%.2f", r.ours_ms / r.peer_ms);
    std::printf("%-22s %9s %9s %9s%s%s\n", r.size.c_str(), peer, ours, ratio, r.note.empty() ? "" : "  ",
                r.note.c_str());
  }
}

nlohmann::json peer_summary_json(const std::vector<PeerRow>& rows, const fs::path& binary, int rounds) {
  nlohmann::json sizes = nlohmann::json::array();
  for (const PeerRow& r : rows) {
    nlohmann::json j = {{"size", r.size}, {"peer_ms", r.peer_ms}, {"ours_ms", r.ours_ms}};
    if (r.peer_ms > 0 && r.ours_ms > 0) j["ours_vs_peer"] = r.ours_ms / r.peer_ms;
    if (!r.note.empty()) j["note"] = r.note;
    sizes.push_back(j);
  }
  return {{"binary", binary.string()}, {"rounds", rounds}, {"warmup_frames", PeerRunInfo{}.warmup}, {"sizes", sizes}};
}

PeerWorkDir::PeerWorkDir() {
  std::error_code ec;
  path = fs::temp_directory_path(ec) / ("gauss-bench-peer-" + std::to_string(::getpid()));
  fs::create_directories(path, ec);  // when it fails, writing the first scene says so, naming the path
}

PeerWorkDir::~PeerWorkDir() {
  std::error_code ec;
  fs::remove_all(path, ec);
}

}  // namespace gauss::bench
