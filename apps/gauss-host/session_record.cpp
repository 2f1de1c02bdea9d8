// SessionRecord (session_record.h): JSON lines through nlohmann::json.
#include "session_record.h"

#include <cstdio>

#include <nlohmann/json.hpp>

namespace gauss::host_app {

Expected<std::unique_ptr<SessionRecord>> SessionRecord::open(const std::filesystem::path& path) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) return Error{"--sessions: cannot write " + path.string()};
  return std::unique_ptr<SessionRecord>(new SessionRecord(std::move(out)));
}

void SessionRecord::write(const std::string& line) {
  out_ << line << '\n';
  out_.flush();  // a script follows the file while the host runs
}

void SessionRecord::listening(const std::string& host, std::uint16_t port, std::uint64_t session_id) {
  char id[17];
  std::snprintf(id, sizeof id, "%016llx", static_cast<unsigned long long>(session_id));
  write(nlohmann::json{{"event", "listening"}, {"host", host}, {"port", port}, {"session", id}}.dump());
}

// Names are bytes from the network: invalid UTF-8 is replaced (U+FFFD) rather than
// failing the dump; well-formed names are written exactly.
void SessionRecord::joined(double t, std::uint32_t client, const std::string& name, std::uint32_t capacity) {
  nlohmann::json j{{"event", "joined"}, {"t", t}, {"client", client}, {"name", name}, {"capacity", capacity}};
  write(j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

void SessionRecord::left(double t, std::uint32_t client, const std::string& name, std::size_t sent,
                         std::uint64_t checksum) {
  nlohmann::json j{{"event", "left"}, {"t", t},       {"client", client},
                   {"name", name},    {"sent", sent}, {"checksum", checksum}};
  write(j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

}  // namespace gauss::host_app
