#include <charconv>

#include "gauss/net/address.h"

namespace gauss::net {

Expected<Endpoint> parse_endpoint(std::string_view text) {
  Endpoint e;
  const auto colon = text.rfind(':');
  const std::string_view host = colon == std::string_view::npos ? text : text.substr(0, colon);
  if (colon != std::string_view::npos) {
    const std::string_view port = text.substr(colon + 1);
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
    if (port.empty() || ec != std::errc{} || end != port.data() + port.size() || value > 65535)
      return Error{"endpoint '" + std::string(text) + "': port '" + std::string(port) + "' is not a number in 0..65535"};
    e.port = static_cast<std::uint16_t>(value);
  }
  if (!host.empty()) e.host = std::string(host);
  if (colon == std::string_view::npos && host.empty()) return Error{"endpoint is empty"};
  return e;
}

std::string to_string(const Endpoint& e) { return e.host + ":" + std::to_string(e.port); }

}  // namespace gauss::net
