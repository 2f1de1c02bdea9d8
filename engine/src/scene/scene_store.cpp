#include "gauss/engine/scene_store.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <string>

#include <glm/common.hpp>

#include "gauss/engine/log_text.h"
#include "gauss/engine/system_memory.h"

namespace gauss {
namespace {

// Names the first non-finite or out-of-contract field, or returns an empty string.
std::string invalid_field(const Gaussian& g, int sh_degree) {
  if (!finite3(g.position)) return "position is not finite";
  if (!finite3(g.log_scale)) return "log_scale is not finite";
  for (int k = 0; k < 4; ++k)
    if (!std::isfinite(g.rotation[k])) return "rotation is not finite";
  if (!std::isfinite(g.opacity_logit)) return "opacity_logit is not finite";
  if (!finite3(g.sh_dc)) return "sh_dc is not finite";
  for (int k = 0; k < kMaxShRest; ++k) {
    if (!finite3(g.sh_rest[k])) return "sh_rest[" + std::to_string(k) + "] is not finite";
    if (k >= sh_rest_count(sh_degree) && g.sh_rest[k] != glm::vec3(0.0f))
      return "sh_rest[" + std::to_string(k) + "] is non-zero above the scene's SH degree " +
             std::to_string(sh_degree);
  }
  if (to_underlying(g.object) < -1) return "object id " + std::to_string(to_underlying(g.object)) + " is negative";
  return {};
}

bool same_object(const SemanticObject& a, const SemanticObject& b) {
  return a.id == b.id && a.label == b.label && a.members == b.members && a.centroid == b.centroid &&
         a.extent_min == b.extent_min && a.extent_max == b.extent_max && a.quality == b.quality;
}

}  // namespace

void Aabb::extend(const glm::vec3& p) {
  min = glm::min(min, p);
  max = glm::max(max, p);
}

Status SceneStore::validate(const Gaussian& g, int sh_degree) {
  if (auto why = invalid_field(g, sh_degree); !why.empty())
    return Error{"Gaussian id " + id_text(g.id) + ": " + why};
  return Ok{};
}

SceneStore::SceneStore(std::size_t change_log_capacity) : log_capacity_(std::max<std::size_t>(1, change_log_capacity)) {}

Status SceneStore::require_open(const char* what) const {
  if (!open_) return Error{std::string("SceneStore::") + what + ": no epoch is open (call begin_epoch first)"};
  return Ok{};
}

Status SceneStore::begin_epoch(Epoch e) {
  if (open_)
    return Error{"SceneStore::begin_epoch(" + std::to_string(to_underlying(e)) + "): epoch " +
                 std::to_string(to_underlying(open_epoch_)) + " is still open"};
  if (to_underlying(e) <= to_underlying(epoch_))
    return Error{"SceneStore::begin_epoch(" + std::to_string(to_underlying(e)) +
                 "): epochs must increase; current epoch is " + std::to_string(to_underlying(epoch_))};
  open_ = true;
  open_epoch_ = e;
  return Ok{};
}

Status SceneStore::begin_next_epoch() { return begin_epoch(Epoch{to_underlying(epoch_) + 1}); }

GaussianId SceneStore::allocate_id() { return GaussianId{next_id_++}; }

Status SceneStore::insert(const Gaussian& g) {
  if (auto s = require_open("insert"); !s) return s;
  if (index_.count(g.id)) return Error{"SceneStore::insert: Gaussian id " + id_text(g.id) + " is already live"};
  if (retired_.contains(g.id))
    return Error{"SceneStore::insert: Gaussian id " + id_text(g.id) + " was removed before; ids are never reused"};
  if (auto why = invalid_field(g, sh_degree_); !why.empty())
    return Error{"SceneStore::insert: Gaussian id " + id_text(g.id) + ": " + why};
  const auto slot = static_cast<std::uint32_t>(gaussians_.size());
  index_.emplace(g.id, slot);
  gaussians_.push_back(g);
  pending_.push_back(Pending::Inserted);
  touched_.push_back(slot);
  next_id_ = std::max(next_id_, to_underlying(g.id) + 1);
  if (!g.carrier) ++appearance_count_;
  return Ok{};
}

Status SceneStore::modify(const Gaussian& g) {
  if (auto s = require_open("modify"); !s) return s;
  auto it = index_.find(g.id);
  if (it == index_.end()) return Error{"SceneStore::modify: Gaussian id " + id_text(g.id) + " is not live"};
  if (auto why = invalid_field(g, sh_degree_); !why.empty())
    return Error{"SceneStore::modify: Gaussian id " + id_text(g.id) + ": " + why};
  Gaussian& stored = gaussians_[it->second];
  if (same_value(stored, g)) return Ok{};
  if (stored.carrier != g.carrier) {
    if (g.carrier)
      --appearance_count_;
    else
      ++appearance_count_;
  }
  stored = g;
  // An id inserted in this epoch stays "inserted"; consumers see only its final record.
  if (pending_[it->second] == Pending::None) {
    pending_[it->second] = Pending::Modified;
    touched_.push_back(it->second);
  }
  return Ok{};
}

Status SceneStore::remove(GaussianId id) {
  if (auto s = require_open("remove"); !s) return s;
  auto it = index_.find(id);
  if (it == index_.end()) return Error{"SceneStore::remove: Gaussian id " + id_text(id) + " is not live"};
  const std::uint32_t i = it->second;
  if (!gaussians_[i].carrier) --appearance_count_;
  index_.erase(it);
  retired_.insert(id);
  Pending& p = pending_[i];
  if (p == Pending::None) touched_.push_back(i);
  p = (p == Pending::Inserted) ? Pending::InsertedThenRemoved : Pending::Removed;
  return Ok{};
}

const Gaussian* SceneStore::find(GaussianId id) const {
  auto it = index_.find(id);
  return it == index_.end() ? nullptr : &gaussians_[it->second];
}

Status SceneStore::set_sh_degree(int degree) {
  if (degree < 0 || degree > kMaxShDegree)
    return Error{"SceneStore::set_sh_degree: degree " + std::to_string(degree) + " is outside 0.." +
                 std::to_string(kMaxShDegree)};
  for (std::size_t i = 0; i < gaussians_.size(); ++i) {
    if (dead(pending_[i])) continue;
    for (int k = sh_rest_count(degree); k < kMaxShRest; ++k)
      if (gaussians_[i].sh_rest[k] != glm::vec3(0.0f))
        return Error{"SceneStore::set_sh_degree(" + std::to_string(degree) + "): Gaussian id " +
                     id_text(gaussians_[i].id) + " has non-zero sh_rest[" + std::to_string(k) + "]"};
  }
  sh_degree_ = degree;
  return Ok{};
}

const SemanticObject* SceneStore::find_object(ObjectId id) const {
  auto it = std::lower_bound(objects_.begin(), objects_.end(), id,
                             [](const SemanticObject& o, ObjectId v) { return to_underlying(o.id) < to_underlying(v); });
  return (it != objects_.end() && it->id == id) ? &*it : nullptr;
}

Status SceneStore::set_object(ObjectId id, std::string label, float quality) {
  if (auto s = require_open("set_object"); !s) return s;
  if (to_underlying(id) < 0)
    return Error{"SceneStore::set_object: object id " + std::to_string(to_underlying(id)) + " is negative"};
  if (label.empty()) return Error{"SceneStore::set_object: object " + std::to_string(to_underlying(id)) + " has an empty label"};
  if (!(quality >= 0.0f && quality <= 1.0f))
    return Error{"SceneStore::set_object: object " + std::to_string(to_underlying(id)) + " quality " +
                 std::to_string(quality) + " is outside [0, 1]"};
  auto& d = declared_[id];
  if (d.label != label || d.quality != quality) pending_objects_changed_ = true;
  d.label = std::move(label);
  d.quality = quality;
  return Ok{};
}

Status SceneStore::remove_object(ObjectId id) {
  if (auto s = require_open("remove_object"); !s) return s;
  if (declared_.erase(id) == 0)
    return Error{"SceneStore::remove_object: object " + std::to_string(to_underlying(id)) + " is not declared"};
  pending_objects_changed_ = true;
  return Ok{};
}

Status SceneStore::validate(const TriangleMesh& m) {
  if (m.colors.size() != m.positions.size())
    return Error{std::to_string(m.colors.size()) + " colours for " + std::to_string(m.positions.size()) + " positions"};
  if (m.indices.size() % 3 != 0)
    return Error{"index count " + std::to_string(m.indices.size()) + " is not a multiple of 3"};
  for (std::size_t i = 0; i < m.positions.size(); ++i)
    if (!finite3(m.positions[i])) return Error{"vertex " + std::to_string(i) + " is not finite"};
  for (std::size_t i = 0; i < m.indices.size(); ++i)
    if (m.indices[i] >= m.positions.size())
      return Error{"index " + std::to_string(i) + " = " + std::to_string(m.indices[i]) + " is out of range (" +
                   std::to_string(m.positions.size()) + " vertices)"};
  return Ok{};
}

Status SceneStore::set_surface_chunk(SurfaceChunk chunk) {
  if (auto s = require_open("set_surface_chunk"); !s) return s;
  if (auto s = validate(chunk.mesh); !s)
    return Error{"SceneStore::set_surface_chunk: chunk " + std::to_string(chunk.chunk_id) + ": " + s.message()};
  chunk.epoch = open_epoch_;
  auto it = std::lower_bound(chunks_.begin(), chunks_.end(), chunk.chunk_id,
                             [](const SurfaceChunk& c, std::uint32_t v) { return c.chunk_id < v; });
  pending_chunks_.push_back(chunk.chunk_id);
  if (it != chunks_.end() && it->chunk_id == chunk.chunk_id)
    *it = std::move(chunk);
  else
    chunks_.insert(it, std::move(chunk));
  return Ok{};
}

Status SceneStore::remove_surface_chunk(std::uint32_t chunk_id) {
  if (auto s = require_open("remove_surface_chunk"); !s) return s;
  auto it = std::lower_bound(chunks_.begin(), chunks_.end(), chunk_id,
                             [](const SurfaceChunk& c, std::uint32_t v) { return c.chunk_id < v; });
  if (it == chunks_.end() || it->chunk_id != chunk_id)
    return Error{"SceneStore::remove_surface_chunk: chunk " + std::to_string(chunk_id) + " does not exist"};
  chunks_.erase(it);
  pending_chunks_.push_back(chunk_id);
  return Ok{};
}

void SceneStore::recompute_derived() {
  bounds_ = Aabb{};
  struct Acc {
    std::vector<GaussianId> members;
    glm::dvec3 sum{0.0};
    Aabb box;
  };
  std::unordered_map<ObjectId, Acc> acc;
  for (const Gaussian& g : gaussians_) {
    if (g.carrier) continue;
    bounds_.extend(g.position);
    if (g.object == kNoObject) continue;
    Acc& a = acc[g.object];
    a.members.push_back(g.id);
    a.sum += glm::dvec3(g.position);
    a.box.extend(g.position);
  }
  std::vector<SemanticObject> next;
  next.reserve(declared_.size() + acc.size());
  for (const auto& [id, d] : declared_) {
    SemanticObject o;
    o.id = id;
    o.label = d.label;
    o.quality = d.quality;
    next.push_back(std::move(o));
  }
  for (const auto& [id, a] : acc)
    if (!declared_.count(id)) {
      SemanticObject o;
      o.id = id;
      o.quality = 0.0f;  // undeclared: nothing upstream vouched for it
      next.push_back(std::move(o));
    }
  for (SemanticObject& o : next) {
    auto it = acc.find(o.id);
    if (it == acc.end()) continue;
    Acc& a = it->second;
    std::sort(a.members.begin(), a.members.end());
    o.centroid = glm::vec3(a.sum / double(a.members.size()));
    o.extent_min = a.box.min;
    o.extent_max = a.box.max;
    o.members = std::move(a.members);
  }
  std::sort(next.begin(), next.end(),
            [](const SemanticObject& x, const SemanticObject& y) { return to_underlying(x.id) < to_underlying(y.id); });
  bool changed = pending_objects_changed_ || next.size() != objects_.size();
  for (std::size_t i = 0; !changed && i < next.size(); ++i) changed = !same_object(next[i], objects_[i]);
  pending_objects_changed_ = changed;
  objects_ = std::move(next);
}

// Per Gaussian beyond the span's own record: its pending mark and touched place (5 bytes),
// its index entry (a hash node of id and place, about 32 bytes with the allocator's header,
// and its bucket) and what a commit's recomputation of object members holds (8).
constexpr std::size_t kStoreBytesPerGaussian = 5 + 48 + 8;

std::size_t SceneStore::bytes_to_hold(std::size_t span) const {
  const std::size_t now = gaussians_.size();
  std::size_t bytes = span > now ? (span - now) * kStoreBytesPerGaussian : 0;
  // A span beyond the capacity is moved into a new buffer: both are held while it moves.
  if (span > gaussians_.capacity()) bytes += span * sizeof(Gaussian);
  return bytes;
}

Status SceneStore::reserve(std::size_t span) {
  if (open_) return Error{"SceneStore::reserve: an epoch is open"};
  if (span <= gaussians_.size()) return Ok{};
  const std::size_t need = bytes_to_hold(span);
  const auto refuse = [&](const std::string& why) {
    return Error{"not enough memory: a scene of " + std::to_string(span) + " Gaussians needs about " +
                 format_bytes(need) + " more, " + why};
  };
  const auto headroom = memory_headroom();
  if (headroom && need > headroom->bytes)
    return refuse("and " + headroom->text());
  // Growth by half the capacity at a time, as push_back would have grown, where that fits
  // too: a trainer's snapshots grow a little each, and room for exactly each would move the
  // whole span (and rehash the index) every epoch.
  std::size_t room = span;
  if (span > gaussians_.capacity()) {
    const std::size_t grown = gaussians_.capacity() + gaussians_.capacity() / 2;
    if (grown > span && (!headroom || bytes_to_hold(grown) <= headroom->bytes)) room = grown;
  }
  // Each reserve leaves its container as it was when it throws; those that succeeded only
  // hold spare capacity.
  try {
    gaussians_.reserve(room);
    pending_.reserve(room);
    touched_.reserve(room);
    index_.reserve(room);
  } catch (const std::bad_alloc&) {
    return refuse("and allocating it failed");
  }
  return Ok{};
}

Status SceneStore::commit_epoch() {
  if (auto s = require_open("commit_epoch"); !s) return s;
  EpochChanges c;
  c.epoch = open_epoch_;
  std::vector<std::uint32_t> holes;
  for (std::uint32_t slot : touched_) {
    switch (pending_[slot]) {
      case Pending::Inserted: c.inserted.push_back(gaussians_[slot].id); break;
      case Pending::Modified: c.modified.push_back(gaussians_[slot].id); break;
      case Pending::Removed: c.removed.push_back(gaussians_[slot].id); break;
      case Pending::InsertedThenRemoved:
      case Pending::None: break;
    }
    if (dead(pending_[slot])) holes.push_back(slot);
  }
  const bool gaussians_changed = !touched_.empty();
  for (std::uint32_t slot : touched_) pending_[slot] = Pending::None;
  touched_.clear();
  // Fill each hole (highest first) with the last Gaussian: O(removed), and only the moved
  // Gaussian's index entry changes. A hole that is itself last just shrinks the span.
  std::sort(holes.begin(), holes.end(), std::greater<>());
  for (std::uint32_t hole : holes) {
    const std::size_t last = gaussians_.size() - 1;
    if (hole != last) {
      gaussians_[hole] = std::move(gaussians_[last]);
      index_[gaussians_[hole].id] = hole;
    }
    gaussians_.pop_back();
    pending_.pop_back();
  }
  if (gaussians_changed || pending_objects_changed_) recompute_derived();

  std::sort(c.inserted.begin(), c.inserted.end());
  std::sort(c.modified.begin(), c.modified.end());
  std::sort(c.removed.begin(), c.removed.end());
  c.objects_changed = pending_objects_changed_;
  std::sort(pending_chunks_.begin(), pending_chunks_.end());
  pending_chunks_.erase(std::unique(pending_chunks_.begin(), pending_chunks_.end()), pending_chunks_.end());
  c.chunks_changed = std::move(pending_chunks_);
  log_.push_back(std::move(c));
  while (log_.size() > log_capacity_) log_.pop_front();

  pending_chunks_.clear();
  pending_objects_changed_ = false;
  epoch_ = open_epoch_;
  open_ = false;
  return Ok{};
}

const EpochChanges* SceneStore::changes(Epoch e) const {
  for (const auto& c : log_)
    if (c.epoch == e) return &c;
  return nullptr;
}

}  // namespace gauss
