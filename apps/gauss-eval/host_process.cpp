#include "host_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>
#include <thread>

#include "seconds_since.h"

namespace gauss::eval_app {

namespace fs = std::filesystem;

namespace {

constexpr auto kPoll = std::chrono::milliseconds(50);

// fork + exec rather than posix_spawn: the child must ask for PR_SET_PDEATHSIG between
// the two, so a gauss-eval killed outright (SIGKILL, a crash) still takes its host along.
// Returns the child's pid, or -errno.
pid_t spawn(const fs::path& exe, const std::vector<std::string>& args, int log_fd) {
  std::vector<std::string> all{exe.string()};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t parent = ::getpid();
  const pid_t pid = ::fork();
  if (pid < 0) return -errno;
  if (pid == 0) {
    // Only async-signal-safe calls until exec.
    if (::prctl(PR_SET_PDEATHSIG, SIGTERM) != 0 || ::getppid() != parent) ::_exit(126);
    ::dup2(log_fd, STDOUT_FILENO);
    ::dup2(log_fd, STDERR_FILENO);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  return pid;
}

}  // namespace

Expected<std::unique_ptr<HostProcess>> HostProcess::start(const fs::path& exe, const std::vector<std::string>& args,
                                                          const fs::path& log, double timeout_s) {
  std::error_code ec;
  if (!fs::is_regular_file(exe, ec) || ::access(exe.c_str(), X_OK) != 0)
    return Error{"no gauss-host executable at " + exe.string() + " (build the gauss-host target, or give --host-exe)"};
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return Error{"cannot write the host's log " + log.string() + ": " + std::strerror(errno)};
  const pid_t pid = spawn(exe, args, fd);
  ::close(fd);
  if (pid < 0) return Error{"cannot start " + exe.string() + ": " + std::strerror(-pid)};
  std::unique_ptr<HostProcess> host(new HostProcess(pid, log));
  // The port it bound (we asked for port 0: any free one, so no other process can take
  // it between our choosing and its binding).
  static const std::regex serving(R"(gauss-host: serving .*: (\d+) Gaussians, .* on [^ ]+:(\d+), session)");
  const auto t0 = std::chrono::steady_clock::now();
  while (true) {
    std::smatch m;
    const std::string text = host->log_text();
    if (std::regex_search(text, m, serving)) {
      host->first_gaussians_ = std::stoull(m[1].str());
      host->port_ = static_cast<std::uint16_t>(std::stoul(m[2].str()));
      return host;
    }
    if (!host->running()) return host->failure("gauss-host exited before it reported its port");
    if (apps::seconds_since(t0) > timeout_s)
      return host->failure("gauss-host did not report its port within " + std::to_string(int(timeout_s)) + " s");
    std::this_thread::sleep_for(kPoll);
  }
}

HostProcess::~HostProcess() { (void)stop(); }

bool HostProcess::running() {
  if (exited_ || pid_ <= 0) return false;
  int status = 0;
  if (::waitpid(pid_, &status, WNOHANG) != pid_) return true;
  exited_ = true;
  exit_status_ = WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
  return false;
}

std::string HostProcess::log_text() const {
  std::ifstream in(log_);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string HostProcess::log_tail() const {
  const std::string text = log_text();
  std::size_t start = text.size(), lines = 0;
  while (start > 0 && lines < 8)
    if (text[--start] == '\n' && start + 1 < text.size()) ++lines;
  return text.substr(start);
}

Error HostProcess::failure(const std::string& what) {
  std::string why = what;
  if (!running() && exited_) why += " (exit status " + std::to_string(exit_status_) + ")";
  (void)stop();
  return Error{why + "; the end of its log " + log_.string() + ":\n" + log_tail()};
}

Expected<std::uint64_t> HostProcess::wait_final_epoch(double timeout_s) {
  static const std::regex final_line(R"(epoch (\d+) \(final\) clients)");
  const auto t0 = std::chrono::steady_clock::now();
  while (true) {
    std::smatch m;
    const std::string text = log_text();
    if (std::regex_search(text, m, final_line)) return std::stoull(m[1].str());
    if (!running()) return failure("gauss-host exited before its scene was complete");
    if (apps::seconds_since(t0) > timeout_s)
      return failure("gauss-host's scene was not complete (no \"(final)\" status line) within " +
                     std::to_string(int(timeout_s)) + " s");
    std::this_thread::sleep_for(kPoll);
  }
}

Expected<fs::path> HostProcess::wait_dump(const std::string& stem, double timeout_s) {
  // The dump's own line, printed after both of its files were written.
  static const std::regex wrote(R"(gauss-host: wrote (.*) \(\d+ Gaussians\))");
  const std::string failed = "--dump-sent for client ";
  const std::string whose = "(" + stem + "): ";
  const auto t0 = std::chrono::steady_clock::now();
  while (true) {
    const std::string text = log_text();
    for (auto it = std::sregex_iterator(text.begin(), text.end(), wrote); it != std::sregex_iterator(); ++it) {
      const fs::path p = (*it)[1].str();
      if (p.filename() == stem + ".ply") return p;
    }
    for (std::size_t at = text.find(failed); at != std::string::npos; at = text.find(failed, at + 1)) {
      const std::size_t eol = text.find('\n', at);
      const std::string line = text.substr(at, eol == std::string::npos ? std::string::npos : eol - at);
      if (line.find(whose) != std::string::npos) return Error{"gauss-host could not write its dump: " + line};
    }
    if (!running()) return failure("gauss-host exited before it wrote the dump of " + stem);
    if (apps::seconds_since(t0) > timeout_s)
      return failure("gauss-host wrote no dump of " + stem + " within " + std::to_string(int(timeout_s)) +
                     " s of the client leaving");
    std::this_thread::sleep_for(kPoll);
  }
}

Expected<int> HostProcess::stop(double grace_s) {
  if (pid_ <= 0) return exit_status_;
  if (running()) {
    ::kill(pid_, SIGTERM);
    const auto t0 = std::chrono::steady_clock::now();
    while (running() && apps::seconds_since(t0) < grace_s) std::this_thread::sleep_for(kPoll);
    if (running()) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      // SIGKILL cannot be ignored; the bound is only against a kernel that never delivers.
      const auto t1 = std::chrono::steady_clock::now();
      while (::waitpid(pid_, &status, WNOHANG) != pid_) {
        if (apps::seconds_since(t1) > 5.0) return Error{"gauss-host (pid " + std::to_string(pid_) + ") survived SIGKILL"};
        std::this_thread::sleep_for(kPoll);
      }
      exited_ = true;
      exit_status_ = -SIGKILL;
    }
  }
  pid_ = -1;
  return exit_status_;
}

}  // namespace gauss::eval_app
