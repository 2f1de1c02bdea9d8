// memory_headroom(): the least of MemAvailable, the cgroup limits above this process and its
// address-space limit, which the host's LoD hierarchy and snapshot loads ask before they
// grow. The parsers on well-formed and broken texts, and the address-space limit in a child.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "address_space_limit.h"
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

TEST(SystemMemory, ACgroupLimitLeavesItsLimitLessWhatCannotBeReclaimed) {
  // v2: 2 GiB limit, 1.5 GiB charged of which 0.25 GiB is inactive file cache.
  const char* stat2 = "anon 1073741824\nfile 402653184\nactive_file 134217728\ninactive_file 268435456\n";
  EXPECT_EQ(cgroup_headroom_of("2147483648\n", "1610612736\n", stat2), std::size_t{805306368});
  // v1's usage counts the descendants, as its total_inactive_file does; its inactive_file is
  // the cgroup's own.
  const char* stat1 = "cache 100\ninactive_file 10\ntotal_inactive_file 1000\n";
  EXPECT_EQ(cgroup_headroom_of("5000", "3000", stat1), std::size_t{3000});
  EXPECT_EQ(cgroup_headroom_of("5000", "3000", ""), std::size_t{2000});  // no memory.stat: all usage counts
  EXPECT_EQ(cgroup_headroom_of("5000", "7000", ""), std::size_t{0});      // over its limit: none left
  EXPECT_EQ(cgroup_headroom_of("5000", "100", stat1), std::size_t{5000});  // cache above usage
  // No limit: v2's "max", v1's largest page-aligned figure. Broken texts are unknown.
  EXPECT_FALSE(cgroup_headroom_of("max\n", "1000\n", ""));
  EXPECT_FALSE(cgroup_headroom_of("9223372036854771712\n", "1000\n", ""));
  EXPECT_FALSE(cgroup_headroom_of("", "1000", ""));
  EXPECT_FALSE(cgroup_headroom_of("5000", "many", ""));
  EXPECT_FALSE(cgroup_headroom_of("5000 bytes", "1000", ""));
  EXPECT_FALSE(cgroup_headroom_of("-5000", "1000", ""));
}

TEST(SystemMemory, FindsThisProcesssCgroupOfEitherVersion) {
  const char* hybrid =
      "9:name=systemd:/\n"
      "4:memory:/process_api/31231c53\n"
      "3:cpu,cpuacct:/\n"
      "0::/user.slice/session-2.scope\n";
  EXPECT_EQ(cgroup_path_of(hybrid, false), std::optional<std::string_view>("/process_api/31231c53"));
  EXPECT_EQ(cgroup_path_of(hybrid, true), std::optional<std::string_view>("/user.slice/session-2.scope"));
  EXPECT_EQ(cgroup_path_of("7:cpu,memory,pids:/docker/abc", false), std::optional<std::string_view>("/docker/abc"));
  EXPECT_EQ(cgroup_path_of("0::/", true), std::optional<std::string_view>("/"));
  EXPECT_FALSE(cgroup_path_of("0::/", false));                    // pure v2: no memory controller line
  EXPECT_FALSE(cgroup_path_of("4:memory:/a\n", true));
  EXPECT_FALSE(cgroup_path_of("4:memoryx:/a\n3:xmemory:/b", false));  // names match whole
  EXPECT_FALSE(cgroup_path_of("garbage\n0:/\n::", true));
}

TEST(SystemMemory, ReadsTheVirtualSizeInPages) {
  EXPECT_EQ(vm_size_of("2500 300 200 10 0 150 0\n", 4096), std::size_t{2500} * 4096u);
  EXPECT_FALSE(vm_size_of("", 4096));
  EXPECT_FALSE(vm_size_of("x 300\n", 4096));
  EXPECT_FALSE(vm_size_of("99999999999999999999 1\n", 4096));
  EXPECT_FALSE(vm_size_of("18446744073709551615 1\n", 4096));  // overflows in bytes
  EXPECT_FALSE(vm_size_of("2500 1\n", 0));
}

TEST(SystemMemory, ThisMachineSaysHowMuchItHas) {
  if (!std::filesystem::exists("/proc/meminfo")) GTEST_SKIP() << "no /proc/meminfo here";
  const auto h = memory_headroom();
  ASSERT_TRUE(h.has_value());
  EXPECT_GT(h->bytes, std::size_t{16} << 20);  // this test runs, so there is some
  EXPECT_FALSE(h->bound.empty());
}

// Under `ulimit -v` the machine has plenty and allocations fail anyway: the address-space
// limit is the one that binds, and what it leaves is the limit less the process's size.
TEST(SystemMemory, AnAddressSpaceLimitBindsBelowWhatTheMachineHas) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "ASan's allocator maps more than the room this test leaves";
#endif
  if (!std::filesystem::exists("/proc/self/statm")) GTEST_SKIP() << "no /proc/self/statm here";
  EXPECT_EXIT(
      {
        const std::size_t room = std::size_t{64} << 20;
        test::AddressSpaceLimit limit(room);
        if (!limit.set()) std::_Exit(3);
        const auto h = memory_headroom();
        if (!h) std::_Exit(4);
        if (h->bound != "the address-space limit (ulimit -v)") std::_Exit(5);
        // The reads above may have mapped a little more.
        std::_Exit(h->bytes <= room && h->bytes + (std::size_t{16} << 20) >= room ? 0 : 6);
      },
      ::testing::ExitedWithCode(0), "");
}

// The limits of a cgroup and of its ancestors all bind; levels without files (the root, or a
// host's path that a container does not show) are passed over.
TEST(SystemMemory, EveryCgroupLimitAboveTheProcessBinds) {
  namespace fs = std::filesystem;
  const fs::path mount = fs::path(::testing::TempDir()) / ("cgroup_" + std::to_string(getpid()));
  fs::remove_all(mount);
  const auto write = [](const fs::path& p, const std::string& text) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << text;
  };
  // v2: the slice allows 3000 more, the leaf 5000 - 1000 = 4000 more.
  write(mount / "slice" / "memory.max", "10000\n");
  write(mount / "slice" / "memory.current", "7000\n");
  write(mount / "slice" / "leaf" / "memory.max", "5000\n");
  write(mount / "slice" / "leaf" / "memory.current", "1500\n");
  write(mount / "slice" / "leaf" / "memory.stat", "anon 1000\ninactive_file 500\n");
  EXPECT_EQ(cgroup_headroom_below(mount, "/slice/leaf", true), std::size_t{3000});
  // A leaf without a limit of its own is bound by its parent's; one whose parent has none, by its own.
  write(mount / "slice" / "open" / "memory.max", "max\n");
  write(mount / "slice" / "open" / "memory.current", "100\n");
  EXPECT_EQ(cgroup_headroom_below(mount, "/slice/open", true), std::size_t{3000});
  write(mount / "slice" / "memory.max", "max\n");
  EXPECT_EQ(cgroup_headroom_below(mount, "/slice/leaf", true), std::size_t{4000});
  EXPECT_FALSE(cgroup_headroom_below(mount, "/slice/open", true));
  // A path the mount does not have, or one outside the namespace's root, reads what exists.
  EXPECT_EQ(cgroup_headroom_below(mount / "slice" / "leaf", "/docker/abc", true), std::size_t{4000});
  EXPECT_EQ(cgroup_headroom_below(mount / "slice" / "leaf", "/../../x", true), std::size_t{4000});
  // v1's file names.
  write(mount / "v1" / "memory.limit_in_bytes", "8192\n");
  write(mount / "v1" / "memory.usage_in_bytes", "4096\n");
  EXPECT_EQ(cgroup_headroom_below(mount, "/v1", false), std::size_t{4096});
  EXPECT_FALSE(cgroup_headroom_below(mount, "/v1", true));
  fs::remove_all(mount);
}
