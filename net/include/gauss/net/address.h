#pragma once
// "HOST:PORT" endpoints for the ENet transport. The default bind is loopback:
// a host is reachable from other machines only when asked to be.
#include <cstdint>
#include <string>
#include <string_view>

#include "gauss/engine/result.h"

namespace gauss::net {

inline constexpr const char* kDefaultBindHost = "127.0.0.1";
inline constexpr std::uint16_t kDefaultPort = 47600;

struct Endpoint {
  std::string host{kDefaultBindHost};  // dotted IPv4 or a resolvable name
  std::uint16_t port{kDefaultPort};    // 0 = any free port (bind only)
};

// Parses "HOST:PORT", "HOST" (default port) or ":PORT" (default host). Fails on an
// empty host, a port outside 0..65535 or trailing junk, naming the text.
Expected<Endpoint> parse_endpoint(std::string_view text);
std::string to_string(const Endpoint& e);

}  // namespace gauss::net
