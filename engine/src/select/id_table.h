#pragma once
// Private to selection and diffing: id -> value tables that stay O(1) without hashing in
// the hot path. Host ids are handed out sequentially (SceneStore::allocate_id), so ids
// below kDenseIdLimit live in a flat array indexed by id; larger ids (e.g. a PLY's own
// gaussian_id values) fall back to a hash map, correct but slower.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "gauss/engine/ids.h"

namespace gauss::select_detail {

// 2^26 ids: 64M entries at most, reached only if a session really allocates that many.
inline constexpr std::uint64_t kDenseIdLimit = std::uint64_t{1} << 26;

template <class T>
class IdTable {
 public:
  // Value for id, or nullptr when absent.
  const T* find(GaussianId id) const {
    const std::uint64_t k = to_underlying(id);
    if (k < kDenseIdLimit) {
      return (k < present_.size() && present_[k]) ? &dense_[k] : nullptr;
    }
    auto it = sparse_.find(k);
    return it == sparse_.end() ? nullptr : &it->second;
  }
  T* find(GaussianId id) { return const_cast<T*>(static_cast<const IdTable*>(this)->find(id)); }
  bool contains(GaussianId id) const { return find(id) != nullptr; }

  // Inserts or overwrites.
  void set(GaussianId id, const T& v) {
    const std::uint64_t k = to_underlying(id);
    if (k < kDenseIdLimit) {
      if (k >= present_.size()) {
        const std::size_t n = std::max<std::size_t>(static_cast<std::size_t>(k) + 1, present_.size() * 3 / 2);
        present_.resize(n, 0);
        dense_.resize(n);
      }
      count_ += present_[k] ? 0 : 1;
      present_[k] = 1;
      dense_[k] = v;
      return;
    }
    count_ += sparse_.count(k) ? 0 : 1;
    sparse_[k] = v;
  }
  void erase(GaussianId id) {
    const std::uint64_t k = to_underlying(id);
    if (k < kDenseIdLimit) {
      if (k < present_.size() && present_[k]) {
        present_[k] = 0;
        --count_;
      }
      return;
    }
    count_ -= sparse_.erase(k);
  }
  void clear() {
    present_.assign(present_.size(), 0);
    sparse_.clear();
    count_ = 0;
  }
  std::size_t size() const { return count_; }

 private:
  std::vector<std::uint8_t> present_;
  std::vector<T> dense_;
  std::unordered_map<std::uint64_t, T> sparse_;
  std::size_t count_ = 0;
};

}  // namespace gauss::select_detail
