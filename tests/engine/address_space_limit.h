#pragma once
// For death-test children that check what happens when allocations fail: the process's
// address-space limit (RLIMIT_AS) set to what it maps now plus `room` bytes, and put back
// when this goes out of scope. A child, because the limit must not outlive the check.
#include <sys/resource.h>
#include <unistd.h>

#include <cstddef>
#include <fstream>

namespace gauss::test {

class AddressSpaceLimit {
 public:
  explicit AddressSpaceLimit(std::size_t room) {
    std::size_t pages = 0;
    {
      std::ifstream statm("/proc/self/statm");  // its first field: the mapped size in pages
      statm >> pages;
    }
    if (pages == 0 || getrlimit(RLIMIT_AS, &was_) != 0) return;
    rlimit tight = was_;
    tight.rlim_cur = rlim_t(pages * std::size_t(sysconf(_SC_PAGESIZE)) + room);
    set_ = setrlimit(RLIMIT_AS, &tight) == 0;
  }
  ~AddressSpaceLimit() { lift(); }
  AddressSpaceLimit(const AddressSpaceLimit&) = delete;
  AddressSpaceLimit& operator=(const AddressSpaceLimit&) = delete;

  bool set() const { return set_; }
  void lift() {
    if (set_) setrlimit(RLIMIT_AS, &was_);
    set_ = false;
  }

 private:
  rlimit was_{};
  bool set_{false};
};

}  // namespace gauss::test
