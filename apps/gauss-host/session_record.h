#pragma once
// --sessions FILE: gauss-host's machine-readable record, one JSON object per line, written
// and flushed as it happens, for scripts (scripts/soak) that must not parse log text: a
// client's name is its own choice and a log line can only show it escaped.
//   {"event":"listening","host":"127.0.0.1","port":7777,"session":"00c0ffee00c0ffee"}
//   {"event":"joined","t":1.25,"client":1,"name":"soak-0-r1","capacity":2000}
//   {"event":"left","t":31.5,"client":1,"name":"soak-0-r1","sent":2000,"checksum":1234}
// t is seconds since the host started; `name` is the Hello's name exactly (JSON escapes
// what needs it); checksum is HostSession::sent_checksum, what the client's published set
// hashes to once it converged (ClientState::published_checksum). Only sessions the host
// accepted appear.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "gauss/engine/result.h"

namespace gauss::host_app {

class SessionRecord {
 public:
  // Creates (truncates) `path`. Errors name the file.
  static Expected<std::unique_ptr<SessionRecord>> open(const std::filesystem::path& path);

  void listening(const std::string& host, std::uint16_t port, std::uint64_t session_id);
  void joined(double t, std::uint32_t client, const std::string& name, std::uint32_t capacity);
  void left(double t, std::uint32_t client, const std::string& name, std::size_t sent, std::uint64_t checksum);

 private:
  explicit SessionRecord(std::ofstream out) : out_(std::move(out)) {}
  void write(const std::string& line);
  std::ofstream out_;
};

}  // namespace gauss::host_app
