// GpuPublication: dirty slot ranges and committed surface chunks onto the GPU.
#include "gauss/client/gpu_publication.h"

#include <vector>

namespace gauss::client {

PreparedSlots GpuPublication::prepare_slots(const SlotTable& slots, std::span<const SlotRange> ranges,
                                            const render::SlotLayout& layout, std::span<std::byte> pack) {
  PreparedSlots out;
  out.layout = layout;
  const auto& records = slots.records();
  const std::size_t per_slot = layout.bytes_per_slot();
  const auto room = static_cast<std::uint32_t>(per_slot == 0 ? 0 : pack.size() / per_slot);
  // The pack buffer's three areas, `room` slots each.
  std::byte* core = pack.data();
  std::byte* sh = core + std::size_t{room} * layout.core_bytes();
  std::byte* sh_high = sh + std::size_t{room} * layout.sh_bytes();
  const std::uint32_t chunk = std::max(layout.chunk_slots, 1u);
  auto occupied = [&](std::uint32_t s) {
    GaussianId id{0};
    return slots.occupant(SlotIndex{s}, id);
  };
  auto add = [](std::vector<SlotRange>& runs, std::uint32_t first, std::uint32_t count) {
    if (!runs.empty() && runs.back().first + runs.back().count == first) {
      runs.back().count += count;
    } else {
      runs.push_back({first, count});
    }
  };
  for (const SlotRange& r : ranges) {
    const std::uint32_t end = r.first + r.count;
    if (end > records.size() || end < r.first) {
      out.error = "GpuPublication: slot range [" + std::to_string(r.first) + ", " + std::to_string(end) +
                  ") outside the slot table";
      return out;
    }
    std::uint32_t s = r.first;
    while (s < end) {
      const bool occ = occupied(s);
      std::uint32_t e = s + 1;
      while (e < end && occupied(e) == occ) ++e;
      ++out.runs;
      if (!occ) {
        out.cleared.push_back({s, e - s});
        s = e;
        continue;
      }
      // Packed piece by piece within slot chunks while the buffer has room.
      for (std::uint32_t a = s; a < e;) {
        const std::uint32_t piece = std::min(e, (a / chunk + 1) * chunk) - a;
        const std::uint32_t n = std::min(piece, room - out.packed_slots);
        if (n == 0) {
          add(out.unpacked, a, e - a);
          break;
        }
        const std::uint32_t at = out.packed_slots;
        out.good.resize(std::size_t{at} + n);
        render::pack_slots(layout, std::span<const Gaussian>(records.data() + a, n),
                           core + std::size_t{at} * layout.core_bytes(), sh + std::size_t{at} * layout.sh_bytes(),
                           sh_high + std::size_t{at} * layout.sh_high_bytes(), out.good.data() + at);
        out.packed.push_back({a, n, VkDeviceSize{at} * layout.core_bytes(),
                              static_cast<VkDeviceSize>(sh - core) + VkDeviceSize{at} * layout.sh_bytes(),
                              static_cast<VkDeviceSize>(sh_high - core) + VkDeviceSize{at} * layout.sh_high_bytes(), at});
        out.packed_slots += n;
        a += n;
      }
      s = e;
    }
  }
  return out;
}

Expected<PublicationResult> GpuPublication::publish_prepared(const PreparedSlots& prepared, const vk::Buffer* source,
                                                             const SlotTable& slots, render::SplatRenderer& renderer,
                                                             bool tint_edits) {
  if (!prepared.error.empty()) return Error{prepared.error};
  PublicationResult out;
  out.runs = prepared.runs;
  // A written slot is "added" (it was free or held another Gaussian: an update and a
  // replacement both read as a change in place).
  auto tint = [&](std::uint32_t first, std::uint32_t count) -> Status {
    if (!tint_edits) return Ok{};
    return renderer.set_edit_tints(first, count, {render::EditTintKind::Added, 0});
  };
  if (!prepared.packed.empty()) {
    if (source == nullptr) return Error{"GpuPublication: packed slot runs without their buffer"};
    if (auto st = renderer.queue_packed_slots(*source, prepared.layout, prepared.packed, prepared.good); !st)
      return st.error();
    for (const render::PackedSlotRun& r : prepared.packed) {
      out.slots_written += r.count;
      out.slots_packed += r.count;
      if (auto st = tint(r.first_slot, r.count); !st) return st.error();
    }
  }
  const auto& records = slots.records();
  for (const SlotRange& r : prepared.unpacked) {
    if (auto st = renderer.write_slots(r.first, std::span<const Gaussian>(records.data() + r.first, r.count)); !st)
      return st.error();
    out.slots_written += r.count;
    if (auto st = tint(r.first, r.count); !st) return st.error();
  }
  // Cleared at once (clearing also resets the tint): an empty slot is skipped before its
  // tint is read, so a removal has nothing to fade.
  for (const SlotRange& r : prepared.cleared) {
    if (auto st = renderer.clear_slots(r.first, r.count); !st) return st.error();
    out.slots_cleared += r.count;
  }
  stats_.slots_written += out.slots_written;
  stats_.slots_cleared += out.slots_cleared;
  stats_.write_calls += out.runs;
  return out;
}

Expected<PublicationResult> GpuPublication::publish_slots(const SlotTable& slots, std::span<const SlotRange> ranges,
                                                          render::SplatRenderer& renderer, bool tint_edits) {
  return publish_prepared(prepare_slots(slots, ranges, renderer.slot_layout(), {}), nullptr, slots, renderer,
                          tint_edits);
}

std::uint32_t GpuPublication::publish_surface(const SurfaceStage& surface, render::SplatRenderer& renderer) {
  return publish_prepared_surface(prepare_surface(surface), renderer);
}

PreparedSurface GpuPublication::prepare_surface(const SurfaceStage& surface) const {
  PreparedSurface out;
  if (surface.revision() == surface_revision_) return out;
  out.changed = true;
  out.revision = surface.revision();
  out.generation = surface.generation();
  // Another generation: the host restarted and its epochs are not comparable with those
  // held, so every chunk is compared afresh (as if none matched).
  const bool restarted = surface.generation() != surface_generation_;
  const auto& committed = surface.committed();
  // Removed: held on the GPU, no longer committed.
  for (const auto& [id, epoch] : gpu_chunks_)
    if (committed.count(id) == 0) out.removed.push_back(id);
  for (const auto& [id, chunk] : committed) {
    auto held = gpu_chunks_.find(id);
    if (!restarted && held != gpu_chunks_.end() && held->second == chunk.epoch) continue;
    if (chunk.mesh.indices.empty()) {
      if (held != gpu_chunks_.end()) out.removed.push_back(id);
      continue;
    }
    PreparedSurface::Set set{id, chunk.epoch, {}, {}};
    if (auto p = render::prepare_mesh_chunk(id, chunk.mesh)) set.chunk = std::move(*p);
    else set.error = p.message();
    out.sets.push_back(std::move(set));
  }
  return out;
}

std::uint32_t GpuPublication::publish_prepared_surface(const PreparedSurface& prepared,
                                                       render::SplatRenderer& renderer) {
  if (!prepared.changed) return 0;
  surface_revision_ = prepared.revision;
  if (prepared.generation != surface_generation_) {
    // A chunk refused below must not match its old epoch later either.
    surface_generation_ = prepared.generation;
    for (auto& [id, epoch] : gpu_chunks_) epoch = Epoch{~std::uint64_t{0}};
  }
  std::uint32_t changed = 0;
  for (std::uint64_t id : prepared.removed) {
    renderer.remove_mesh_chunk(id);
    gpu_chunks_.erase(id);
    ++stats_.chunks_removed;
    ++changed;
  }
  for (const PreparedSurface::Set& set : prepared.sets) {
    Status st = set.error.empty() ? renderer.set_mesh_chunk(set.id, set.chunk) : Status(Error{set.error});
    if (!st) {
      ++stats_.chunks_refused;
      stats_.last_refusal = st.message();
      continue;  // the previous version of the chunk (if any) stays
    }
    gpu_chunks_[set.id] = set.epoch;
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
