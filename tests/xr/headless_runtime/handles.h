#pragma once
// Handle tables: every OpenXR handle the runtime gives out is an id from one counter that
// only grows, so a destroyed handle, a handle of another type or a made-up value is never
// found again and the call returns XR_ERROR_HANDLE_INVALID instead of touching freed memory.
#include <cstdint>
#include <map>
#include <memory>
#include <vector>

namespace gauss::xr_headless {

// The next unused handle id (never 0, the null handle). Callers hold the runtime lock.
std::uint64_t next_handle_id();

template <class H>
H to_handle(std::uint64_t id) {
  return reinterpret_cast<H>(static_cast<std::uintptr_t>(id));
}

template <class H>
std::uint64_t to_id(H handle) {
  return static_cast<std::uint64_t>(reinterpret_cast<std::uintptr_t>(handle));
}

template <class T>
class HandleTable {
 public:
  // The live object with this id, or nullptr.
  T* find(std::uint64_t id) const {
    auto it = items_.find(id);
    return it == items_.end() ? nullptr : it->second.get();
  }

  std::uint64_t insert(std::unique_ptr<T> item) {
    const std::uint64_t id = next_handle_id();
    items_.emplace(id, std::move(item));
    return id;
  }

  std::unique_ptr<T> remove(std::uint64_t id) {
    auto it = items_.find(id);
    if (it == items_.end()) return nullptr;
    auto out = std::move(it->second);
    items_.erase(it);
    return out;
  }

  // Ids of the objects for which `pred(const T&)` holds, in creation order.
  template <class Pred>
  std::vector<std::uint64_t> ids_where(Pred pred) const {
    std::vector<std::uint64_t> out;
    for (const auto& [id, item] : items_)
      if (pred(*item)) out.push_back(id);
    return out;
  }

 private:
  std::map<std::uint64_t, std::unique_ptr<T>> items_;
};

}  // namespace gauss::xr_headless
