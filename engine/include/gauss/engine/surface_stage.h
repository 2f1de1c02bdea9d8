#pragma once
// SurfaceStage: holds received surface (TSDF mesh) chunk patches until the epoch
// barrier lets them through. A chunk of epoch e is committed only when every Gaussian
// edit of epochs <= e has been published or superseded, so at every frame
//   epoch(published surface) <= epoch(published Gaussians).
// Per chunk, a newer patch replaces an older pending one (latest value wins); a patch
// older than what is pending or committed for that chunk is rejected and counted; the
// same epoch again (a resync resends the surface) is a no-op.
#include <cstdint>
#include <map>
#include <optional>

#include "gauss/engine/ids.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/result.h"

namespace gauss {

// One chunk patch (msg::SurfacePatch's content). An empty mesh removes the chunk.
struct StagedChunk {
  std::uint64_t chunk_id{0};
  Epoch epoch{0};
  TriangleMesh mesh;
};

struct SurfaceStats {
  std::uint64_t offered{0};
  std::uint64_t superseded{0};      // pending patch replaced by a newer one
  std::uint64_t duplicates{0};      // same chunk, same epoch again (resync): ignored
  std::uint64_t rejected_stale{0};  // older than the chunk's pending/committed epoch
  std::uint64_t rejected_bad{0};    // malformed mesh (index out of range, colour count)
  std::uint64_t dropped_on_resync{0};  // held chunks a resync did not resend (removed)
  std::uint64_t committed{0};
};

class SurfaceStage {
 public:
  // Queues a received patch. Errors name the chunk and why; the stage is untouched.
  Status offer(StagedChunk chunk);
  // A resync of epoch `e` has resent every chunk the scene holds (the host sends them
  // before the resync batch, on the same ordered channel). A chunk held here, committed
  // or pending, whose newest patch is older than `e` was dropped by the scene while the
  // connection was down: its removal is staged at `e`, behind the barrier like any
  // patch. Returns the number of removals staged.
  std::uint32_t drop_not_resent(Epoch e);
  // The host restarted (a Welcome of another host session): its epochs count from the
  // start again, so the held epochs mean nothing to it. The committed chunks stay on show
  // without an epoch (committed_epoch() is nullopt until the next commit); pending patches
  // are dropped. The new session's resync resends every chunk its scene holds (accepted
  // whatever their epochs) and drop_not_resent() removes the chunks it did not resend.
  void restart_epochs();
  // Commits every pending patch whose epoch <= the Gaussian published epoch; returns
  // the number committed. nullopt (nothing published yet) commits nothing.
  std::uint32_t commit(std::optional<Epoch> published_gaussian_epoch);

  // Highest epoch among committed chunks (nullopt before the first commit).
  std::optional<Epoch> committed_epoch() const noexcept { return committed_epoch_; }
  const std::map<std::uint64_t, StagedChunk>& committed() const noexcept { return committed_; }
  std::size_t pending_count() const noexcept { return pending_.size(); }
  // Bumped on every commit that changed the committed surface (the renderer re-uploads).
  std::uint64_t revision() const noexcept { return revision_; }
  // Bumped by restart_epochs(): epochs of different generations are not comparable, so a
  // consumer that keys what it holds by chunk epoch re-checks every chunk.
  std::uint64_t generation() const noexcept { return generation_; }
  const SurfaceStats& stats() const noexcept { return stats_; }

 private:
  std::map<std::uint64_t, StagedChunk> pending_;
  std::map<std::uint64_t, StagedChunk> committed_;
  // Newest epoch accepted per chunk of this host session, removed ones too. A committed
  // chunk missing here was received from an earlier host session.
  std::map<std::uint64_t, Epoch> latest_;
  std::optional<Epoch> committed_epoch_;
  std::uint64_t revision_{0};
  std::uint64_t generation_{0};
  SurfaceStats stats_;
};

}  // namespace gauss
