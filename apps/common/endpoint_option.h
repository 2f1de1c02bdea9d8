#pragma once
// A CLI11 check for HOST:PORT options (the programs that use the network: gauss-host's
// --bind, gauss-view's --host), with net::parse_endpoint's message on a bad value.
#include <string>

#include <CLI/CLI.hpp>

#include "gauss/net/address.h"

namespace gauss::apps {

inline CLI::Validator endpoint() {
  return CLI::Validator(
      [](std::string& in) -> std::string {
        auto e = net::parse_endpoint(in);
        return e ? std::string{} : e.message();
      },
      "");
}

}  // namespace gauss::apps
