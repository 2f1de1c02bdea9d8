// WorkerPool: every index of every loop runs exactly once, whatever the thread count
// and loop size, and a loop returns only when all its items have.
#include <atomic>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "gauss/net/worker_pool.h"

namespace gauss {
namespace {

TEST(WorkerPool, EveryIndexRunsOncePerLoop) {
  for (unsigned threads : {1u, 2u, 3u, 8u}) {
    net::WorkerPool pool(threads);
    EXPECT_EQ(pool.threads(), threads);
    for (std::size_t n : {std::size_t{0}, std::size_t{1}, std::size_t{2}, std::size_t{7}, std::size_t{1000}}) {
      for (int loop = 0; loop < 20; ++loop) {
        std::vector<std::atomic<int>> hits(n);
        pool.parallel_for(n, [&](std::size_t i) { hits[i].fetch_add(1); });
        for (std::size_t i = 0; i < n; ++i) ASSERT_EQ(hits[i].load(), 1) << threads << " threads, n " << n << ", item " << i;
      }
    }
  }
}

TEST(WorkerPool, ItemsRunOnSeveralThreadsAndTheLoopWaitsForAll) {
  net::WorkerPool pool(4);
  std::atomic<int> running{0}, most{0}, done{0};
  pool.parallel_for(8, [&](std::size_t) {
    const int now = running.fetch_add(1) + 1;
    int seen = most.load();
    while (now > seen && !most.compare_exchange_weak(seen, now)) {
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    running.fetch_sub(1);
    done.fetch_add(1);
  });
  EXPECT_EQ(done.load(), 8) << "parallel_for returned before its items";
  EXPECT_GT(most.load(), 1) << "the items never overlapped";
}

TEST(WorkerPool, ZeroMeansOnePerHardwareThread) {
  net::WorkerPool pool(0);
  EXPECT_EQ(pool.threads(), std::max(1u, std::thread::hardware_concurrency()));
}

}  // namespace
}  // namespace gauss
