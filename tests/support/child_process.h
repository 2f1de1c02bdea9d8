#pragma once
// Child processes for the tests that run the real programs (gauss-host, gauss-view,
// gauss-render): started with posix_spawn, output to a log file, waited for with a time
// bound, and on timeout or test exit ended by THEIR pid only (SIGTERM, then SIGKILL).
// Also a free loopback UDP port for a host to bind (ENet is UDP).
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <fcntl.h>
#include <filesystem>
#include <optional>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace gauss::test {

// A UDP port on 127.0.0.1 that was free a moment ago (bind to 0, read, close). Another
// process may take it in between; callers retry with a new port if the host cannot bind.
inline std::uint16_t free_udp_port() {
  const int fd = ::socket(AF_INET, SOCK_DGRAM, 0);
  if (fd < 0) return 0;
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = 0;
  std::uint16_t port = 0;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0) {
    socklen_t len = sizeof a;
    if (::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0) port = ntohs(a.sin_port);
  }
  ::close(fd);
  return port;
}

class ChildProcess {
 public:
  ChildProcess() = default;
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  ~ChildProcess() { stop(); }

  // Starts `argv[0]` with `argv`, stdout and stderr appended to `log`. False on failure.
  bool start(const std::vector<std::string>& argv, const std::filesystem::path& log) {
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    const int rc = posix_spawn(&pid_, args[0], &fa, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) pid_ = -1;
    return pid_ > 0;
  }

  bool running() const noexcept { return pid_ > 0; }

  // Waits up to `timeout` for the child to exit; its exit code, or nullopt on timeout
  // (the child is then still running) or a death by signal (-signal).
  std::optional<int> wait(std::chrono::milliseconds timeout) {
    if (pid_ <= 0) return exit_code_;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (true) {
      int status = 0;
      const pid_t r = ::waitpid(pid_, &status, WNOHANG);
      if (r == pid_) {
        pid_ = -1;
        exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
        return exit_code_;
      }
      if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }

  // Asks the child to stop (SIGINT: the programs exit cleanly on it), then SIGKILL
  // after `grace`. Returns the exit code (or -signal).
  std::optional<int> stop(int signal = SIGINT, std::chrono::milliseconds grace = std::chrono::milliseconds(10000)) {
    if (pid_ <= 0) return exit_code_;
    ::kill(pid_, signal);
    if (auto rc = wait(grace)) return rc;
    ::kill(pid_, SIGKILL);
    return wait(std::chrono::milliseconds(5000));
  }

 private:
  pid_t pid_{-1};
  std::optional<int> exit_code_;
};

}  // namespace gauss::test
