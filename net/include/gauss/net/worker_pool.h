#pragma once
// WorkerPool: a fixed set of threads for data-parallel loops, used by SessionHost to run
// every client's selection + diff + encode (HostSession::tick) of one pump at once. The
// sessions share one scene store, which a pump only reads (epochs are committed between
// pumps), and each session owns everything it writes, so the ticks need no locks.
//
// parallel_for(n, fn) calls fn(0..n-1) once each, spread over the pool's threads and the
// calling thread, and returns when all have returned. Calls must not overlap (one loop at
// a time: SessionHost calls it from its pump thread only). fn must not throw.
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace gauss::net {

class WorkerPool {
 public:
  // `threads` counts the calling thread: 1 runs every loop inline; 0 means one per
  // hardware thread.
  explicit WorkerPool(unsigned threads);
  ~WorkerPool();
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  unsigned threads() const noexcept { return static_cast<unsigned>(workers_.size()) + 1; }
  void parallel_for(std::size_t n, const std::function<void(std::size_t)>& fn);

 private:
  void run_worker();
  void drain();  // takes indices of the current loop until none is left

  std::vector<std::thread> workers_;
  std::mutex mu_;
  std::condition_variable start_, done_;
  const std::function<void(std::size_t)>* fn_{nullptr};
  std::size_t n_{0}, next_{0}, finished_{0};
  std::uint64_t generation_{0};
  bool stop_{false};
};

}  // namespace gauss::net
