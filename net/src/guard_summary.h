#pragma once
// The host's one log line per interval about connections that never became clients and
// clients it dropped: the counts that changed since the last line (HostCounters), so a
// flood of thousands of refusals a second costs one line, and a quiet interval none.
#include <string>

#include "gauss/net/host.h"

namespace gauss::net::detail {

// "admission, last 10.0 s: 4211 connections, 1 accepted; refused 4200 (...); ..." or
// empty when no guarded count changed. `last_rejection` is appended escaped.
std::string guard_summary(const HostCounters& now, const HostCounters& before, double seconds);

}  // namespace gauss::net::detail
