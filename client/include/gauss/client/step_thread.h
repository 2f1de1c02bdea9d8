#pragma once
// StepThread: one worker thread that runs one step at a time for a caller that must never
// wait for it (the display thread). request() hands a job over only when the worker is
// idle and its last result was taken; take() returns a finished result, if any. Neither
// blocks on the step itself: the only lock is held for a handover.
//
//   display frame k:  take() -> result of the step asked for in frame k - 1 (or nothing:
//                     still running; ask again next frame) ... request(job k)
//
// wait_idle() blocks until no step runs (for work that needs the worker's data quiet,
// such as recreating the renderer; not per frame).
#include <condition_variable>
#include <functional>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>

namespace gauss::client {

template <class Job, class Result>
class StepThread {
 public:
  explicit StepThread(std::function<Result(Job&)> step) : step_(std::move(step)), thread_([this] { run(); }) {}
  ~StepThread() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    thread_.join();
  }
  StepThread(const StepThread&) = delete;
  StepThread& operator=(const StepThread&) = delete;

  // Starts `job` unless a step runs or a result waits to be taken (then `job` is left as
  // it was and false returned).
  bool request(Job& job) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (busy_ || result_) return false;
      job_.emplace(std::move(job));
      busy_ = true;
    }
    wake_.notify_all();
    return true;
  }
  std::optional<Result> take() {
    std::lock_guard<std::mutex> lock(mutex_);
    std::optional<Result> out;
    out.swap(result_);
    return out;
  }
  // True while a step runs or its result waits.
  bool outstanding() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return busy_ || result_.has_value();
  }
  void wait_idle() {
    std::unique_lock<std::mutex> lock(mutex_);
    idle_.wait(lock, [this] { return !busy_; });
  }

 private:
  void run() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stop_ || job_.has_value(); });
      if (stop_) return;
      Job job = std::move(*job_);
      job_.reset();
      lock.unlock();
      Result r = step_(job);
      lock.lock();
      result_.emplace(std::move(r));
      busy_ = false;
      idle_.notify_all();
    }
  }

  std::function<Result(Job&)> step_;
  mutable std::mutex mutex_;
  std::condition_variable wake_, idle_;
  std::optional<Job> job_;
  std::optional<Result> result_;
  bool busy_{false};
  bool stop_{false};
  std::thread thread_;  // last: starts after the members it reads exist
};

}  // namespace gauss::client
