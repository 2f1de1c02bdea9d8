#pragma once
// A NetClient sink that drops everything: for clients a test only needs connected (a flood's
// source, a calm bystander), whose messages it never reads.
#include <string>

#include "gauss/engine/wire.h"
#include "gauss/net/client.h"

namespace gauss::test {

class NullSink final : public net::ClientSink {
 public:
  void on_welcome(const msg::Welcome&) override {}
  void on_message(wire::Message&&) override {}
  void on_refused(const msg::Refuse&) override {}
  void on_disconnected(const std::string&) override {}
};

}  // namespace gauss::test
