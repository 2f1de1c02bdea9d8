// available_memory_bytes(): MemAvailable from /proc/meminfo, which the host's LoD hierarchy
// asks before it is built; the parser on well-formed and broken texts.
#include <filesystem>

#include <gtest/gtest.h>

#include "gauss/engine/system_memory.h"

using namespace gauss;

TEST(SystemMemory, ReadsMemAvailableInKibibytes) {
  const char* text =
      "MemTotal:       24684084 kB\n"
      "MemFree:        20328904 kB\n"
      "MemAvailable:   24156332 kB\n"
      "Buffers:           14136 kB\n";
  const auto bytes = mem_available_of(text);
  ASSERT_TRUE(bytes.has_value());
  EXPECT_EQ(*bytes, std::size_t{24156332} * 1024u);
  EXPECT_EQ(mem_available_of("MemAvailable: 0 kB"), std::size_t{0});  // last line, no newline
}

TEST(SystemMemory, AnythingElseIsUnknownNotAGuess) {
  EXPECT_FALSE(mem_available_of(""));
  EXPECT_FALSE(mem_available_of("MemTotal: 100 kB\nMemFree: 50 kB\n"));  // an old kernel: no line
  EXPECT_FALSE(mem_available_of("MemAvailable:   lots kB\n"));
  EXPECT_FALSE(mem_available_of("MemAvailable:   -5 kB\n"));
  EXPECT_FALSE(mem_available_of("MemAvailable:   100 MB\n"));            // not the kernel's unit
  EXPECT_FALSE(mem_available_of("MemAvailable:   100\n"));
  EXPECT_FALSE(mem_available_of("MemAvailable:   99999999999999999999999 kB\n"));  // overflows
  EXPECT_FALSE(mem_available_of("XMemAvailable:  100 kB\n"));
}

TEST(SystemMemory, ThisMachineSaysHowMuchItHas) {
  if (!std::filesystem::exists("/proc/meminfo")) GTEST_SKIP() << "no /proc/meminfo here";
  const auto bytes = available_memory_bytes();
  ASSERT_TRUE(bytes.has_value());
  EXPECT_GT(*bytes, std::size_t{16} << 20);  // this test runs, so there is some
}
