#pragma once
// GpuPublication: carries what ClientState published in a display frame onto the GPU.
//  - Slots: for each merged dirty range of the SlotTable, its occupied runs are written
//    (write_slots) and its free runs cleared (clear_slots): both go through the
//    renderer's staging ring and land at the start of the next recorded frame, so only
//    the dirty ranges cross to the GPU and frames in flight never see a half write.
//  - Surface: the SurfaceStage's committed chunks (already behind the epoch barrier) are
//    compared with what the GPU mesh holds (chunk id -> epoch); changed chunks are set,
//    vanished ones removed. Old chunk buffers are destroyed after the frames using them.
//  - Tints: with edit visualisation on, each slot written this frame is tinted "added"
//    from this frame on; the renderer fades the tint with age. Removed Gaussians leave
//    their slot at once (no removal fade: that would need the record kept until it fades).
//
// Bad data: a Gaussian with NaN/Inf is refused by the renderer (its slot cleared,
// counted); a chunk the mesh pass refuses is skipped and counted; the rest goes on.
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "gauss/engine/result.h"
#include "gauss/engine/slot_table.h"
#include "gauss/engine/surface_stage.h"
#include "gauss/render/mesh_pass.h"
#include "gauss/render/splat_renderer.h"

namespace gauss::client {

struct GpuPublicationStats {
  std::uint64_t slots_written{0};   // slots uploaded (occupied)
  std::uint64_t slots_cleared{0};
  std::uint64_t write_calls{0};     // write_slots + clear_slots calls (upload runs)
  std::uint64_t chunks_set{0};
  std::uint64_t chunks_removed{0};
  std::uint64_t chunks_refused{0};
  std::string last_refusal;
};

struct PublicationResult {
  std::uint32_t slots_written{0};
  std::uint32_t slots_packed{0};   // of which packed off the display thread (PreparedSlots)
  std::uint32_t slots_cleared{0};
  std::uint32_t runs{0};
  std::uint32_t chunks_changed{0};
};

// A frame's slot uploads, prepared where the packing costs the display thread nothing
// (GpuPublication::prepare_slots, e.g. on a publication thread): occupied runs packed in
// the renderer's slot layout into a caller's host-visible buffer, and what is left to the
// display thread: free runs to clear, and occupied runs that did not fit the buffer.
struct PreparedSlots {
  std::string error;  // a range outside the slot table (nothing after it prepared)
  render::SlotLayout layout;
  std::vector<render::PackedSlotRun> packed;
  std::vector<std::uint8_t> good;       // per packed slot: stored (1) or refused non-finite (0)
  std::vector<SlotRange> unpacked;      // occupied runs past the pack buffer
  std::vector<SlotRange> cleared;       // free runs
  std::uint32_t packed_slots{0};
  std::uint32_t runs{0};                // occupied and free runs, as publish_slots counts them
};

// A surface change, prepared where checking and converting the meshes costs the display
// thread nothing (GpuPublication::prepare_surface, e.g. on a publication thread under the
// state lock): chunks to remove, and changed chunks in the mesh pass's vertex layout (or
// the reason the mesh pass would refuse them).
struct PreparedSurface {
  bool changed{false};  // the stage moved since the last publication: apply
  std::uint64_t revision{0};
  std::uint64_t generation{0};
  std::vector<std::uint64_t> removed;
  struct Set {
    std::uint64_t id{0};
    Epoch epoch{0};
    std::string error;  // refused (the chunk held before, if any, stays)
    render::PreparedMeshChunk chunk;
  };
  std::vector<Set> sets;
};

class GpuPublication {
 public:
  // Splits `ranges` of `slots` into occupied and free runs and packs occupied runs (split
  // at slot chunks) into `pack` (layout.bytes_per_slot() bytes per slot: core records of
  // every run first, then SH bands 1-2, then band 3) until it is full. Reads the slot
  // table only: thread-safe while no one writes it.
  static PreparedSlots prepare_slots(const SlotTable& slots, std::span<const SlotRange> ranges,
                                     const render::SlotLayout& layout, std::span<std::byte> pack);
  // Queues what prepare_slots made: packed runs copied from `source` (the buffer `pack`
  // was; kept unchanged until the frame recording them has finished), unpacked runs
  // written and free runs cleared through the renderer's staging ring, edit tints.
  Expected<PublicationResult> publish_prepared(const PreparedSlots& prepared, const vk::Buffer* source,
                                               const SlotTable& slots, render::SplatRenderer& renderer, bool tint_edits);
  // Uploads `ranges` (this frame's merged dirty ranges) of `slots`. Errors: a range past
  // the renderer's capacity (nothing after it is written).
  Expected<PublicationResult> publish_slots(const SlotTable& slots, std::span<const SlotRange> ranges,
                                            render::SplatRenderer& renderer, bool tint_edits);
  // Brings the renderer's mesh to the stage's committed surface (only when it changed):
  // prepare_surface then publish_prepared_surface.
  std::uint32_t publish_surface(const SurfaceStage& surface, render::SplatRenderer& renderer);
  // What publish_surface would change, against what the GPU holds now: reads `surface`
  // and this object only, so it may run on another thread while nothing publishes.
  PreparedSurface prepare_surface(const SurfaceStage& surface) const;
  // Applies a prepare_surface result made since the last publication; returns the chunks
  // changed.
  std::uint32_t publish_prepared_surface(const PreparedSurface& prepared, render::SplatRenderer& renderer);
  // Everything again, into a new (empty) renderer, e.g. one made for another SH degree.
  Status republish_all(const SlotTable& slots, const SurfaceStage& surface, render::SplatRenderer& renderer);

  const GpuPublicationStats& stats() const noexcept { return stats_; }
  std::size_t gpu_chunk_count() const noexcept { return gpu_chunks_.size(); }

 private:
  std::map<std::uint64_t, Epoch> gpu_chunks_;  // what the renderer's mesh holds
  std::uint64_t surface_revision_{~std::uint64_t{0}};
  std::uint64_t surface_generation_{0};  // SurfaceStage::generation() the epochs above belong to
  GpuPublicationStats stats_;
};

}  // namespace gauss::client
