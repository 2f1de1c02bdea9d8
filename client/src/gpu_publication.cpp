// GpuPublication: dirty slot ranges and committed surface chunks onto the GPU.
#include "gauss/client/gpu_publication.h"

#include <vector>

namespace gauss::client {

Expected<PublicationResult> GpuPublication::publish_slots(const SlotTable& slots, std::span<const SlotRange> ranges,
                                                          render::SplatRenderer& renderer, bool tint_edits) {
  PublicationResult out;
  const auto& records = slots.records();
  auto occupied = [&](std::uint32_t s) {
    GaussianId id{0};
    return slots.occupant(SlotIndex{s}, id);
  };
  for (const SlotRange& r : ranges) {
    const std::uint32_t end = r.first + r.count;
    if (end > records.size() || end < r.first)
      return Error{"GpuPublication: slot range [" + std::to_string(r.first) + ", " + std::to_string(end) +
                   ") outside the slot table"};
    std::uint32_t s = r.first;
    while (s < end) {
      const bool occ = occupied(s);
      std::uint32_t e = s + 1;
      while (e < end && occupied(e) == occ) ++e;
      if (occ) {
        if (auto st = renderer.write_slots(s, std::span<const Gaussian>(records.data() + s, e - s)); !st) return st.error();
        out.slots_written += e - s;
        // A written slot is "added" (it was free or held another Gaussian: an update and a
        // replacement both read as a change in place).
        if (tint_edits)
          if (auto st = renderer.set_edit_tints(s, e - s, {render::EditTintKind::Added, 0}); !st) return st.error();
      } else {
        // Cleared at once (clearing also resets the tint): an empty slot is skipped before
        // its tint is read, so a removal has nothing to fade.
        if (auto st = renderer.clear_slots(s, e - s); !st) return st.error();
        out.slots_cleared += e - s;
      }
      ++out.runs;
      s = e;
    }
  }
  stats_.slots_written += out.slots_written;
  stats_.slots_cleared += out.slots_cleared;
  stats_.write_calls += out.runs;
  return out;
}

std::uint32_t GpuPublication::publish_surface(const SurfaceStage& surface, render::SplatRenderer& renderer) {
  if (surface.revision() == surface_revision_) return 0;
  surface_revision_ = surface.revision();
  if (surface.generation() != surface_generation_) {
    // The host restarted: its epochs are not comparable with those held, so every chunk
    // is compared afresh (a never-matching epoch forces the upload).
    surface_generation_ = surface.generation();
    for (auto& [id, epoch] : gpu_chunks_) epoch = Epoch{~std::uint64_t{0}};
  }
  std::uint32_t changed = 0;
  const auto& committed = surface.committed();
  // Removed: held on the GPU, no longer committed.
  for (auto it = gpu_chunks_.begin(); it != gpu_chunks_.end();) {
    if (committed.count(it->first) == 0) {
      renderer.remove_mesh_chunk(it->first);
      ++stats_.chunks_removed;
      ++changed;
      it = gpu_chunks_.erase(it);
    } else {
      ++it;
    }
  }
  for (const auto& [id, chunk] : committed) {
    auto held = gpu_chunks_.find(id);
    if (held != gpu_chunks_.end() && held->second == chunk.epoch) continue;
    if (chunk.mesh.indices.empty()) {
      if (held != gpu_chunks_.end()) {
        renderer.remove_mesh_chunk(id);
        gpu_chunks_.erase(held);
        ++stats_.chunks_removed;
        ++changed;
      }
      continue;
    }
    if (auto st = renderer.set_mesh_chunk(id, chunk.mesh); !st) {
      ++stats_.chunks_refused;
      stats_.last_refusal = st.message();
      continue;  // the previous version of the chunk (if any) stays
    }
    gpu_chunks_[id] = chunk.epoch;
    ++stats_.chunks_set;
    ++changed;
  }
  return changed;
}

Status GpuPublication::republish_all(const SlotTable& slots, const SurfaceStage& surface,
                                     render::SplatRenderer& renderer) {
  gpu_chunks_.clear();
  surface_revision_ = ~std::uint64_t{0};
  // A new renderer starts with every slot empty: only the occupied runs go up.
  std::vector<SlotRange> occupied;
  for (std::uint32_t k = 0; k < slots.capacity(); ++k) {
    GaussianId id{0};
    if (!slots.occupant(SlotIndex{k}, id)) continue;
    if (!occupied.empty() && occupied.back().first + occupied.back().count == k) {
      ++occupied.back().count;
    } else {
      occupied.push_back({k, 1});
    }
  }
  auto r = publish_slots(slots, occupied, renderer, false);
  if (!r) return r.error();
  publish_surface(surface, renderer);
  return Ok{};
}

}  // namespace gauss::client
