#pragma once
// Zero-copy ENet packets over a shared encoded frame, with a per-connection count of
// bytes ENet still holds (queued or unacknowledged). ENet destroys a reliable packet
// once every fragment is acknowledged, and calls its freeCallback then; that is the
// moment the bytes stop counting. The count is what host policy uses to hold back
// new epochs for a client whose link is behind (the differ diffs against what was
// sent, so skipping an epoch for one client loses nothing).
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include <enet/enet.h>

namespace gauss::net::detail {

using Frame = std::shared_ptr<const std::vector<std::uint8_t>>;
using ByteCounter = std::shared_ptr<std::atomic<std::int64_t>>;

struct PacketRef {
  Frame frame;
  ByteCounter pending;
};

inline void free_packet_ref(ENetPacket* packet) {
  auto* ref = static_cast<PacketRef*>(packet->userData);
  if (ref == nullptr) return;
  if (ref->pending) ref->pending->fetch_sub(static_cast<std::int64_t>(packet->dataLength));
  packet->userData = nullptr;
  delete ref;
}

// A packet that points into `frame` (kept alive until ENet frees the packet).
// Returns nullptr when ENet cannot allocate the packet header.
inline ENetPacket* make_packet(const Frame& frame, bool reliable, const ByteCounter& pending) {
  const enet_uint32 flags = enet_uint32{ENET_PACKET_FLAG_NO_ALLOCATE} | (reliable ? enet_uint32{ENET_PACKET_FLAG_RELIABLE} : 0u);
  // ENet never writes through the data pointer of a NO_ALLOCATE packet it sends.
  ENetPacket* p = enet_packet_create(const_cast<std::uint8_t*>(frame->data()), frame->size(), flags);
  if (p == nullptr) return nullptr;
  p->userData = new PacketRef{frame, pending};
  p->freeCallback = &free_packet_ref;
  if (pending) pending->fetch_add(static_cast<std::int64_t>(frame->size()));
  return p;
}

}  // namespace gauss::net::detail
