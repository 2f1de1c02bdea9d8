#pragma once
// gauss-host as a child process of gauss-eval --realtime: started with its output in a log
// file, read back from that log (the port it bound, its status line, the dumps it wrote),
// and always ended by gauss-eval, by its pid: SIGTERM, then SIGKILL after a bound; also
// when gauss-eval fails (the destructor), and when gauss-eval itself dies (the child asks
// the kernel for SIGTERM when its parent thread exits: PR_SET_PDEATHSIG).
//
// The log is the host's contract with scripts (scripts/demo reads the same lines):
//   "gauss-host: serving ... on 127.0.0.1:PORT, session ..."  once it listens;
//   "t=  N.Ns epoch E (final) clients ..."                   once a second after its last epoch;
//   "gauss-host: wrote DIR/NAME.ply (N Gaussians)"            after a --dump-sent dump;
//   "gauss-host: --dump-sent for client ...: WHY"             after a failed one.
// Every wait here is bounded and fails naming what did not come, with the log's tail.
#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "gauss/engine/result.h"

namespace gauss::eval_app {

class HostProcess {
 public:
  // Starts `exe` with `args` (output to `log`) and waits up to `timeout_s` for the port it
  // reports. Errors: no executable at `exe`, fork failure, the host exited or said nothing
  // of a port in time (the child is then ended).
  static Expected<std::unique_ptr<HostProcess>> start(const std::filesystem::path& exe,
                                                      const std::vector<std::string>& args,
                                                      const std::filesystem::path& log, double timeout_s);
  ~HostProcess();  // stop()
  HostProcess(const HostProcess&) = delete;
  HostProcess& operator=(const HostProcess&) = delete;

  pid_t pid() const noexcept { return pid_; }
  std::uint16_t port() const noexcept { return port_; }
  // The Gaussian count of the first epoch, from the "serving" line.
  std::uint64_t first_epoch_gaussians() const noexcept { return first_gaussians_; }
  const std::filesystem::path& log() const noexcept { return log_; }

  // Waits for the status line that says the scene will not change again; returns its epoch.
  // Errors: the host exited, or no such line within `timeout_s`.
  Expected<std::uint64_t> wait_final_epoch(double timeout_s);
  // Waits for the host's dump of the client named `stem` (DIR/stem.ply, written when that
  // client's session ended); returns its path. Errors: the host reported the dump failed,
  // exited, or wrote nothing within `timeout_s`.
  Expected<std::filesystem::path> wait_dump(const std::string& stem, double timeout_s);

  // Ends the host: SIGTERM, SIGKILL after `grace_s`, reaped. Returns its exit status
  // (-signal when a signal ended it); idempotent. Error: it could not be reaped even
  // after SIGKILL (should not happen).
  Expected<int> stop(double grace_s = 10.0);

 private:
  HostProcess(pid_t pid, std::filesystem::path log) : pid_(pid), log_(std::move(log)) {}
  // Reaps the child if it has exited (status kept); true while it runs.
  bool running();
  std::string log_text() const;
  // The last lines of the log, for error messages.
  std::string log_tail() const;
  // An error naming the host's exit status (when it exited) and the log's tail.
  Error failure(const std::string& what);

  pid_t pid_{-1};
  std::filesystem::path log_;
  std::uint16_t port_{0};
  std::uint64_t first_gaussians_{0};
  int exit_status_{0};
  bool exited_{false};
};

}  // namespace gauss::eval_app
