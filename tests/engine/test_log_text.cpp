// escape_for_log (log_text.h): what a hostile client name can and cannot do to a log line.
#include <gtest/gtest.h>

#include <string>

#include "gauss/engine/log_text.h"

namespace gauss {
namespace {

// Nothing a terminal or a line-based parser acts on survives: no byte below 0x20, no DEL,
// no C1 control, and no quote that could close the quotes around a logged name.
bool inert(const std::string& s) {
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto b = static_cast<unsigned char>(s[i]);
    if (b < 0x20 || b == 0x7F) return false;
    if (b == 0xC2 && i + 1 < s.size() && static_cast<unsigned char>(s[i + 1]) < 0xA0) return false;
    if ((b == '\'' || b == '"') && (i == 0 || s[i - 1] != '\\')) return false;
  }
  return true;
}

TEST(LogText, PlainTextPassesUnchanged) {
  EXPECT_EQ(escape_for_log("soak-0-r1"), "soak-0-r1");
  EXPECT_EQ(escape_for_log(""), "");
  EXPECT_EQ(escape_for_log("Quest 3 (living room)"), "Quest 3 (living room)");
}

TEST(LogText, AForgedLogLineStaysOnItsOwnLine) {
  const std::string name = "x' left: sent 1 Gaussians, checksum 1\ngauss-host: client 1 'legit' left: sent 20000 "
                           "Gaussians, checksum 42\r";
  const std::string e = escape_for_log(name);
  EXPECT_EQ(e.find('\n'), std::string::npos);
  EXPECT_EQ(e.find('\r'), std::string::npos);
  EXPECT_EQ(e,
            "x\\' left: sent 1 Gaussians, checksum 1\\ngauss-host: client 1 \\'legit\\' left: sent 20000 Gaussians, "
            "checksum 42\\r");
  EXPECT_TRUE(inert(e));
}

TEST(LogText, TerminalEscapesAndControlsBecomeVisible) {
  EXPECT_EQ(escape_for_log("\x1b[31mred\x1b[0m"), "\\x1b[31mred\\x1b[0m");
  EXPECT_EQ(escape_for_log(std::string("a\0b", 3)), "a\\x00b");
  EXPECT_EQ(escape_for_log("\x07\x08\x7f\t"), "\\x07\\x08\\x7f\\t");
  EXPECT_EQ(escape_for_log("back\\slash \"q\""), "back\\\\slash \\\"q\\\"");
  // C1 CSI (U+009B) is a one-character terminal escape on some terminals.
  EXPECT_EQ(escape_for_log("\xc2\x9b" "2J"), "\\u{009b}2J");
  // A right-to-left override and a line separator would change what a reader sees.
  EXPECT_EQ(escape_for_log("a\xe2\x80\xae" "b\xe2\x80\xa8"), "a\\u{202e}b\\u{2028}");
}

TEST(LogText, WellFormedUtf8StaysReadableAndBrokenUtf8IsShownByteByByte) {
  EXPECT_EQ(escape_for_log("J\xc3\xbcrgen \xe6\x97\xa5\xf0\x9f\x98\x80"), "J\xc3\xbcrgen \xe6\x97\xa5\xf0\x9f\x98\x80");
  EXPECT_EQ(escape_for_log("\xc0\xaf"), "\\xc0\\xaf");              // overlong '/'
  EXPECT_EQ(escape_for_log("\xed\xa0\x80"), "\\xed\\xa0\\x80");    // a surrogate
  EXPECT_EQ(escape_for_log("\xf4\x90\x80\x80"), "\\xf4\\x90\\x80\\x80");  // past U+10FFFF
  EXPECT_EQ(escape_for_log("ok\xe6\x97"), "ok\\xe6\\x97");          // cut mid-character
  EXPECT_EQ(escape_for_log("\xff"), "\\xff");
}

TEST(LogText, EveryByteValueComesOutInert) {
  std::string all;
  for (int b = 0; b < 256; ++b) all += static_cast<char>(b);
  const std::string e = escape_for_log(all);
  EXPECT_TRUE(inert(e)) << e;
  EXPECT_LE(e.size(), all.size() * 10);
}

TEST(LogText, ALongInputIsCutVisibly) {
  EXPECT_EQ(escape_for_log("abcdef", 3), "abc...");
  EXPECT_EQ(escape_for_log("abc", 3), "abc");
  EXPECT_EQ(escape_for_log("\n\n\n\n", 2), "\\n\\n...");
}

}  // namespace
}  // namespace gauss
