#pragma once
// The Publisher's ranking structures. Every operation is O(1) or bounded by a small
// constant, so a frame's upkeep follows the work it is given, never the backlog's size:
//   - Candidate: a pending edit with everything its priority reads (scoring never
//     touches the DesiredEntry, which is five cache lines away in a pool of hundreds of
//     megabytes) and the sequence number of the entry's pending period it stands for.
//   - BucketQueue: candidates by priority quantised into 1024 buckets; push and pop
//     O(1), the best bucket found through a 1024-bit occupancy mask. Order within a
//     bucket is arbitrary (priorities within 1/1024 of the range are treated alike).
//   - RemoveSlots: pending removes by slot within visibility classes, as room for
//     inserts: the least visible class first, in slot order, so a frame's inserts land in
//     runs of consecutive slots (few upload ranges). One bit per slot and class; the
//     lowest set bit is found from a per-class cursor.
#include <array>
#include <bit>
#include <cstdint>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/desired_state.h"
#include "gauss/engine/ids.h"

namespace gauss::detail {

struct Candidate {
  glm::vec3 position{0.0f};  // where the edit shows (a remove: where the published one is)
  float base{0.0f};          // the priority's view- and time-independent part
  double since{0.0};         // pending since (the age term)
  GaussianId id{0};
  std::uint32_t index{0};    // entry index
  std::uint32_t seq{0};      // live while the entry's current sequence number equals it
  SlotIndex slot{kNoSlot};   // the slot a remove or update writes
  PendingKind kind{PendingKind::None};
  std::uint8_t remove_class{0};  // a remove's visibility class when it was last scored
};

class BucketQueue {
 public:
  static constexpr int kBuckets = 1024;

  std::size_t size() const noexcept { return size_; }
  bool empty() const noexcept { return size_ == 0; }
  void push(const Candidate& c, int bucket) {
    buckets_[static_cast<std::size_t>(bucket)].push_back(c);
    mask_[static_cast<std::size_t>(bucket) / 64] |= std::uint64_t{1} << (bucket % 64);
    ++size_;
  }
  // The highest nonempty bucket at or below `from`, or -1.
  int highest(int from = kBuckets - 1) const {
    if (from < 0) return -1;
    int w = from / 64;
    std::uint64_t bits = mask_[static_cast<std::size_t>(w)] & (~std::uint64_t{0} >> (63 - from % 64));
    while (true) {
      if (bits != 0) return w * 64 + 63 - std::countl_zero(bits);
      if (--w < 0) return -1;
      bits = mask_[static_cast<std::size_t>(w)];
    }
  }
  // Takes a candidate of the highest bucket (which must exist).
  Candidate pop(int bucket) {
    auto& v = buckets_[static_cast<std::size_t>(bucket)];
    const Candidate c = v.back();
    v.pop_back();
    --size_;
    if (v.empty()) mask_[static_cast<std::size_t>(bucket) / 64] &= ~(std::uint64_t{1} << (bucket % 64));
    return c;
  }
  // The candidate pop(bucket) would return next, or nullptr (to prefetch what it names).
  const Candidate* peek(int bucket) const {
    const auto& v = buckets_[static_cast<std::size_t>(bucket)];
    return v.empty() ? nullptr : &v.back();
  }
  std::vector<Candidate>& bucket(int b) { return buckets_[static_cast<std::size_t>(b)]; }
  // Removes bucket b's item k by moving its last item there.
  void remove_at(int b, std::size_t k) {
    auto& v = buckets_[static_cast<std::size_t>(b)];
    v[k] = v.back();
    v.pop_back();
    --size_;
    if (v.empty()) mask_[static_cast<std::size_t>(b) / 64] &= ~(std::uint64_t{1} << (b % 64));
  }

 private:
  std::array<std::vector<Candidate>, kBuckets> buckets_;
  std::array<std::uint64_t, kBuckets / 64> mask_{};
  std::size_t size_{0};
};

// A FIFO queue on one growing power-of-two ring: push and pop without allocating once it
// has grown (a deque allocated and freed a block per 32 items, and with glibc trimming the
// heap behind it, faulted its pages in again on every teleport).
template <class T>
class Ring {
 public:
  bool empty() const noexcept { return head_ == tail_; }
  std::size_t size() const noexcept { return tail_ - head_; }
  const T& front() const { return items_[head_ & (items_.size() - 1)]; }
  void pop_front() { ++head_; }
  void push_back(const T& v) {
    if (size() == items_.size()) grow();
    items_[tail_++ & (items_.size() - 1)] = v;
  }

 private:
  void grow() {
    std::vector<T> bigger(items_.empty() ? 1024 : items_.size() * 2);
    for (std::size_t k = 0; k < size(); ++k) bigger[k] = items_[(head_ + k) & (items_.size() - 1)];
    tail_ = size();
    head_ = 0;
    items_.swap(bigger);
  }
  std::vector<T> items_;
  std::size_t head_{0}, tail_{0};  // positions, wrapped by the mask when used
};

class RemoveSlots {
 public:
  static constexpr int kClasses = 17;  // 0: outside the view cone; 1..16: in it, by relevance

  std::uint32_t capacity() const noexcept { return static_cast<std::uint32_t>(class_.size()); }
  void reset(std::uint32_t capacity) {
    const std::size_t words = (std::size_t{capacity} + 63) / 64;
    for (auto& b : bits_) b.assign(words, 0);
    count_.fill(0);
    first_word_.fill(0);
    class_.assign(capacity, 0);
    entry_.assign(capacity, 0);
  }
  std::size_t size() const {
    std::size_t n = 0;
    for (std::uint32_t c : count_) n += c;
    return n;
  }
  // Slot `slot` holds a pending remove of entry `index` in class `cls` (any earlier
  // listing of the slot is replaced).
  void set(std::uint32_t slot, int cls, std::uint32_t index) {
    if (slot >= class_.size()) return;
    clear(slot);
    class_[slot] = static_cast<std::uint8_t>(cls + 1);
    entry_[slot] = index;
    bits_[static_cast<std::size_t>(cls)][slot / 64] |= std::uint64_t{1} << (slot % 64);
    ++count_[static_cast<std::size_t>(cls)];
    first_word_[static_cast<std::size_t>(cls)] = std::min(first_word_[static_cast<std::size_t>(cls)], slot / 64);
  }
  void clear(std::uint32_t slot) {
    if (slot >= class_.size() || class_[slot] == 0) return;
    const int cls = class_[slot] - 1;
    bits_[static_cast<std::size_t>(cls)][slot / 64] &= ~(std::uint64_t{1} << (slot % 64));
    --count_[static_cast<std::size_t>(cls)];
    class_[slot] = 0;
  }
  // The lowest listed slot of class `cls` (with its entry), false when the class is empty.
  bool lowest_in(int cls, std::uint32_t& slot, std::uint32_t& index) {
    const auto c = static_cast<std::size_t>(cls);
    if (count_[c] == 0) return false;
    std::uint32_t& w = first_word_[c];
    while (bits_[c][w] == 0) ++w;  // count_ > 0: a set bit lies at or after the cursor
    slot = w * 64 + static_cast<std::uint32_t>(std::countr_zero(bits_[c][w]));
    index = entry_[slot];
    return true;
  }
  // The lowest listed slot of the least visible nonempty class.
  bool lowest(std::uint32_t& slot, std::uint32_t& index) {
    for (int c = 0; c < kClasses; ++c)
      if (lowest_in(c, slot, index)) return true;
    return false;
  }

 private:
  std::array<std::vector<std::uint64_t>, kClasses> bits_;
  std::array<std::uint32_t, kClasses> count_{};
  std::array<std::uint32_t, kClasses> first_word_{};  // no set bit below this word
  std::vector<std::uint8_t> class_;   // per slot: 0 unlisted, else class + 1
  std::vector<std::uint32_t> entry_;  // per slot: the listed remove's entry index
};

}  // namespace gauss::detail
