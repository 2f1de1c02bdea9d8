#pragma once
// Typed ids: a slot is never confused with a Gaussian id, an object id or an epoch.
#include <cstdint>
#include <functional>

namespace gauss {

// Persistent Gaussian identity, assigned by the host, never reused in a session.
// Ids travel on the wire; slots never do.
enum class GaussianId : std::uint64_t {};
// Semantic object instance; kNoObject marks an unlabelled Gaussian.
enum class ObjectId : std::int32_t {};
inline constexpr ObjectId kNoObject{-1};
// Index into a client's stable-slot GPU buffer (the client's business only).
enum class SlotIndex : std::uint32_t {};
inline constexpr SlotIndex kNoSlot{0xFFFFFFFFu};
// Host source epoch: strictly increasing per host session.
enum class Epoch : std::uint64_t {};

template <class E>
constexpr auto to_underlying(E e) noexcept {
  return static_cast<std::underlying_type_t<E>>(e);
}

}  // namespace gauss
