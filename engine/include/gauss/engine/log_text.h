#pragma once
// Text from the network (client names, query strings, labels, refusal reasons) made safe
// to print in a log line or a report: whoever wrote it cannot start a new line (and forge
// one that a script parses), move the cursor, recolour the terminal or reorder what a
// reader sees. Everything that is not plain printable text becomes a visible escape, so
// nothing is lost and the original bytes can be read back from the escape:
//   \n \r \t \\ \' \"      the usual C escapes (quotes too: a name cannot close the quotes
//                          a log line puts around it)
//   \xNN                   any other ASCII control byte (ESC is \x1b), DEL, and every byte
//                          that is not part of well-formed UTF-8
//   \u{NNNN}               well-formed UTF-8 that is still a control: C1 controls
//                          (U+0080..U+009F, U+009B is a terminal CSI), line and paragraph
//                          separators, bidirectional overrides and isolates ("Trojan
//                          source"), and the byte-order mark
// Other well-formed UTF-8 (accents, CJK, emoji) passes unchanged, so a name stays
// readable. The result is at most 10 bytes per input byte; `max_bytes` (0: no limit)
// bounds the input read, and a cut input ends in "..." so the reader knows.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "gauss/engine/ids.h"

namespace gauss {

std::string escape_for_log(std::string_view text, std::size_t max_bytes = 0);

// A byte count for a message that names a limit: "123 bytes", and from 1 MiB on with the
// MiB beside it, "1468006 bytes (1.4 MiB)" (the exact figure stays for whoever compares it).
std::string format_bytes(std::uint64_t bytes);

// A Gaussian id as decimal text, for messages that name one.
std::string id_text(GaussianId id);

}  // namespace gauss
