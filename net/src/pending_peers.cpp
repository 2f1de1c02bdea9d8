// PendingPeers (pending_peers.h): one pass over the host's peer slots.
#include "pending_peers.h"

#include <algorithm>

namespace gauss::net::detail {

PendingPeers::Sweep PendingPeers::sweep(ENetHost* host, Clock::time_point now, Clock::duration timeout) {
  seen_.resize(host->peerCount);
  Sweep s;
  for (std::size_t i = 0; i < host->peerCount; ++i) {
    ENetPeer& peer = host->peers[i];
    Seen& seen = seen_[i];
    if (peer.state == ENET_PEER_STATE_DISCONNECTED) {
      seen.pending = false;
      ++s.free;
      continue;
    }
    if (peer.state != ENET_PEER_STATE_ACKNOWLEDGING_CONNECT) {
      seen.pending = false;
      continue;
    }
    if (!seen.pending || seen.connect_id != peer.connectID) {
      seen = Seen{peer.connectID, now, true};
    } else if (now - seen.since >= timeout) {
      enet_peer_reset(&peer);  // frees the slot, sends nothing: the requester may be forged
      seen.pending = false;
      ++s.timed_out;
      ++s.free;
    }
  }
  return s;
}

std::size_t PendingPeers::evict_oldest(ENetHost* host, Clock::time_point now, Clock::duration grace,
                                       std::size_t count) {
  std::vector<std::size_t> pending;
  for (std::size_t i = 0; i < seen_.size() && i < host->peerCount; ++i)
    if (seen_[i].pending && host->peers[i].state == ENET_PEER_STATE_ACKNOWLEDGING_CONNECT &&
        host->peers[i].connectID == seen_[i].connect_id && now - seen_[i].since >= grace)
      pending.push_back(i);
  const std::size_t n = std::min(count, pending.size());
  std::partial_sort(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(n), pending.end(),
                    [&](std::size_t a, std::size_t b) { return seen_[a].since < seen_[b].since; });
  for (std::size_t k = 0; k < n; ++k) {
    enet_peer_reset(&host->peers[pending[k]]);
    seen_[pending[k]].pending = false;
  }
  return n;
}

}  // namespace gauss::net::detail
