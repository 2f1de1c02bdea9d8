#include "gauss/engine/surface_stage.h"

#include <string>

namespace gauss {

Status SurfaceStage::offer(StagedChunk chunk) {
  ++stats_.offered;
  // Built only for an error: an accepted patch costs no string.
  auto name = [&chunk] {
    return "surface chunk " + std::to_string(chunk.chunk_id) + " (epoch " + std::to_string(to_underlying(chunk.epoch)) + ")";
  };
  const TriangleMesh& m = chunk.mesh;
  if (m.colors.size() != m.positions.size() || m.indices.size() % 3 != 0) {
    ++stats_.rejected_bad;
    return Error{name() + ": " + std::to_string(m.colors.size()) + " colours for " + std::to_string(m.positions.size()) +
                 " vertices, " + std::to_string(m.indices.size()) + " indices"};
  }
  for (std::size_t i = 0; i < m.indices.size(); ++i) {
    if (m.indices[i] >= m.positions.size()) {
      ++stats_.rejected_bad;
      return Error{name() + ": index " + std::to_string(i) + " = " + std::to_string(m.indices[i]) + " is out of range"};
    }
  }
  auto latest = latest_.find(chunk.chunk_id);
  if (latest != latest_.end() && chunk.epoch == latest->second) {
    // The same chunk of the same epoch again (a resync after a reconnect resends the
    // whole surface): the content is the one already held.
    ++stats_.duplicates;
    return Ok{};
  }
  if (latest != latest_.end() && to_underlying(chunk.epoch) < to_underlying(latest->second)) {
    ++stats_.rejected_stale;
    return Error{name() + ": older than the epoch already held for this chunk"};
  }
  if (pending_.count(chunk.chunk_id)) ++stats_.superseded;
  const std::uint64_t id = chunk.chunk_id;
  latest_.insert_or_assign(id, chunk.epoch);
  pending_.insert_or_assign(id, std::move(chunk));
  return Ok{};
}

std::uint32_t SurfaceStage::drop_not_resent(Epoch e) {
  std::uint32_t n = 0;
  // Chunks of an earlier host session that this session's resync did not resend.
  for (const auto& [id, chunk] : committed_) {
    if (latest_.count(id)) continue;
    latest_.emplace(id, e);
    pending_.insert_or_assign(id, StagedChunk{id, e, {}});
    ++n;
  }
  for (auto& [id, latest] : latest_) {
    if (to_underlying(latest) >= to_underlying(e)) continue;  // resent by this resync (or newer)
    auto pending = pending_.find(id);
    const bool held = committed_.count(id) != 0 || (pending != pending_.end() && !pending->second.mesh.positions.empty());
    if (!held) continue;  // already removed, or its removal is pending
    latest = e;
    pending_.insert_or_assign(id, StagedChunk{id, e, {}});
    ++n;
  }
  stats_.dropped_on_resync += n;
  return n;
}

void SurfaceStage::restart_epochs() {
  ++generation_;
  ++revision_;  // the committed chunks' epochs changed
  pending_.clear();
  latest_.clear();
  for (auto& [id, chunk] : committed_) chunk.epoch = Epoch{0};
  committed_epoch_.reset();
}

std::uint32_t SurfaceStage::commit(std::optional<Epoch> published_gaussian_epoch) {
  if (!published_gaussian_epoch) return 0;
  const std::uint64_t bound = to_underlying(*published_gaussian_epoch);
  std::uint32_t n = 0;
  for (auto it = pending_.begin(); it != pending_.end();) {
    if (to_underlying(it->second.epoch) > bound) {
      ++it;
      continue;
    }
    const Epoch e = it->second.epoch;
    if (!committed_epoch_ || to_underlying(e) > to_underlying(*committed_epoch_)) committed_epoch_ = e;
    if (it->second.mesh.positions.empty())
      committed_.erase(it->first);
    else
      committed_.insert_or_assign(it->first, std::move(it->second));
    it = pending_.erase(it);
    ++n;
  }
  if (n) {
    ++revision_;
    stats_.committed += n;
  }
  return n;
}

}  // namespace gauss
