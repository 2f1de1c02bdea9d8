#include "gauss/engine/host_session.h"

#include <algorithm>
#include <utility>

#include <glm/common.hpp>
#include <glm/gtc/quaternion.hpp>

#include "gauss/engine/query.h"
#include "gauss/engine/scene_view.h"

namespace gauss {

namespace {

std::uint64_t to_us(double seconds) { return seconds <= 0.0 ? 0 : static_cast<std::uint64_t>(seconds * 1e6); }

glm::dvec3 forward_of(const msg::HeadPose& p) {
  const glm::dquat q(p.rotation[0], p.rotation[1], p.rotation[2], p.rotation[3]);
  return q * glm::dvec3(0.0, 0.0, 1.0);  // OpenCV: the head looks along +z
}

msg::ObjectInfo object_info(const SemanticObject& o) {
  msg::ObjectInfo info;
  info.id = o.id;
  info.label = o.label.substr(0, msg::kMaxLabelBytes);
  info.centroid = o.centroid;
  info.extent_min = glm::min(o.extent_min, o.extent_max);
  info.extent_max = glm::max(o.extent_min, o.extent_max);
  info.quality = std::clamp(o.quality, 0.0f, 1.0f);
  info.member_count = static_cast<std::uint32_t>(o.members.size());
  return info;
}

}  // namespace

ClientPose to_client_pose(const msg::HeadPose& pose) {
  ClientPose c;
  c.position = glm::dvec3(pose.position);
  c.orientation = glm::normalize(glm::dquat(pose.rotation[0], pose.rotation[1], pose.rotation[2], pose.rotation[3]));
  c.tan_half_fov_x = std::clamp(static_cast<double>(pose.tan_half_fov_x), 1e-3, 100.0);
  c.tan_half_fov_y = std::clamp(static_cast<double>(pose.tan_half_fov_y), 1e-3, 100.0);
  return c;
}

msg::HeadPose head_pose_from_camera(const Camera& camera) {
  const ClientPose p = ClientPose::from_camera(camera);
  msg::HeadPose h;
  h.position = glm::vec3(p.position);
  const glm::dquat q = glm::normalize(p.orientation);
  h.rotation = {static_cast<float>(q.w), static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)};
  h.tan_half_fov_x = static_cast<float>(p.tan_half_fov_x);
  h.tan_half_fov_y = static_cast<float>(p.tan_half_fov_y);
  return h;
}

HostSession::HostSession(std::uint32_t client_id, std::uint64_t session_id, CodecParams params, HostSessionConfig config)
    : client_id_(client_id),
      session_id_(session_id),
      params_(params),
      config_(std::move(config)),
      selector_(config_.selector),
      differ_(params),
      bucket_(config_.query_burst) {
  if (config_.shared_selector_terms) selector_.share_terms(config_.shared_selector_terms);
  if (config_.lod && config_.shared_lod)
    lod_.emplace(config_.shared_lod, config_.selector);
  else if (config_.lod)
    lod_.emplace(params_.sh_degree, config_.selector, *config_.lod);
}

void HostSession::reject(std::string reason) {
  ++stats_.rejected_messages;
  stats_.last_rejection = std::move(reason);
}

void HostSession::reject(std::uint64_t& counter, std::string reason) {
  ++counter;
  reject(std::move(reason));
}

std::vector<wire::Message> HostSession::on_message(const wire::Message& m, const SceneStore& scene, double now) {
  std::vector<wire::Message> out;
  if (closed_) return out;
  const msg::MessageType type = wire::type_of(m);
  if (msg::direction_of(type) != msg::Direction::ClientToHost) {
    reject(stats_.rejected_direction, std::string("client sent host-only message ") + msg::to_string(type));
    return out;
  }
  if (const auto* hello = std::get_if<msg::Hello>(&m)) {
    if (accepted_) {
      reject(stats_.rejected_duplicate_hello, "second Hello on an accepted connection ignored");
      return out;
    }
    msg::Refuse refuse;
    if (hello->protocol_version != msg::kProtocolVersion) {
      refuse.reason = msg::RefuseReason::VersionMismatch;
      refuse.detail = "protocol version " + std::to_string(hello->protocol_version) + ", host speaks " +
                      std::to_string(msg::kProtocolVersion);
    } else if (!config_.access_token.empty() && hello->access_token != config_.access_token) {
      refuse.reason = msg::RefuseReason::BadToken;
      refuse.detail = hello->access_token.empty() ? "access token required" : "access token does not match";
    } else if (hello->slot_capacity == 0 || hello->slot_capacity > kMaxSlotCapacity) {
      refuse.reason = msg::RefuseReason::BadCapacity;
      refuse.detail = "slot capacity " + std::to_string(hello->slot_capacity) + " outside [1, " +
                      std::to_string(kMaxSlotCapacity) + "]";
    } else {
      accepted_ = true;
      needs_resync_ = true;
      capacity_ = std::min(hello->slot_capacity, std::max(config_.max_capacity, 1u));
      out.push_back(msg::Welcome{msg::kProtocolVersion, session_id_, client_id_, capacity_});
      return out;
    }
    stats_.last_rejection = "Hello refused: " + refuse.detail;
    closed_ = true;
    out.push_back(std::move(refuse));
    return out;
  }
  if (!accepted_) {
    reject(stats_.rejected_before_hello, std::string(msg::to_string(type)) + " before the Hello");
    return out;
  }
  if (const auto* pose = std::get_if<msg::HeadPose>(&m)) {
    if (pose_ && pose->sequence <= pose_->sequence) {
      reject(stats_.stale_poses, "head pose " + std::to_string(pose->sequence) + " not newer than " +
                                     std::to_string(pose_->sequence));
      return out;
    }
    pose_ = *pose;
    follow_pose(*pose, now);
    return out;
  }
  if (const auto* q = std::get_if<msg::Query>(&m)) {
    msg::QueryReply reply;
    reply.query_id = q->query_id;
    reply.epoch = scene.epoch();
    bucket_ = std::min<double>(config_.query_burst, bucket_ + std::max(0.0, now - bucket_time_) * config_.queries_per_s);
    bucket_time_ = now;
    if (bucket_ < 1.0) {
      reply.status = msg::QueryStatus::Rejected;
      reply.reason = "query rate limit (" + std::to_string(config_.queries_per_s) + "/s, burst " +
                     std::to_string(config_.query_burst) + ")";
      reject(stats_.rejected_queries, reply.reason);
      out.push_back(std::move(reply));
      return out;
    }
    bucket_ -= 1.0;
    if (q->kind == msg::QueryKind::Clear) {
      query_.reset();
      rho_ = 0.0;
      query_changed_ = true;
      reply.status = msg::QueryStatus::Cleared;
      out.push_back(std::move(reply));
      return out;
    }
    const SemanticQuery sq = q->kind == msg::QueryKind::ClassText ? SemanticQuery::for_class(q->text)
                                                                   : SemanticQuery::for_instance(q->instance);
    auto res = resolve_query(sq, scene.objects());
    if (!res) {
      reply.status = msg::QueryStatus::NoMatch;
      reply.reason = res.message().substr(0, msg::kMaxReasonBytes);
      out.push_back(std::move(reply));
      return out;
    }
    query_ = sq;
    rho_ = q->rho == msg::kHostDefaultRho ? std::clamp(config_.default_rho, 0.0, 1.0)
                                          : std::clamp(static_cast<double>(q->rho), 0.0, 1.0);
    query_changed_ = true;
    query_id_ = q->query_id;
    reply.status = msg::QueryStatus::Resolved;
    reply.targets = res->ids();
    reply.target_gaussians = res->gaussians;
    const ObjectId first = reply.targets.empty() ? kNoObject : reply.targets.front();
    events_.query(now, client_id_, q->query_id, QueryStage::Resolved, first, reply.targets.size());
    events_.query(now, client_id_, q->query_id, QueryStage::Target, first, res->gaussians);
    out.push_back(std::move(reply));
    return out;
  }
  if (const auto* ack = std::get_if<msg::Ack>(&m)) {
    if (ack->last_batch_id >= next_batch_id_ ||
        (last_ack_ && ack->last_batch_id < last_ack_->last_batch_id)) {
      reject("ack of batch " + std::to_string(ack->last_batch_id) + " out of order or never sent");
      return out;
    }
    last_ack_ = *ack;
    return out;
  }
  // ClientStats: informational; the transport logs it.
  return out;
}

namespace {

// Distance in metres and angle between view directions in radians.
std::pair<double, double> pose_distance(const msg::HeadPose& a, const msg::HeadPose& b) {
  const double d = glm::length(glm::dvec3(a.position) - glm::dvec3(b.position));
  const double c = glm::dot(forward_of(a), forward_of(b));
  return {d, std::acos(std::clamp(c, -1.0, 1.0))};
}

}  // namespace

void HostSession::follow_pose(const msg::HeadPose& pose, double now) {
  // Stillness is measured from where it began, so a slow drift in small steps is motion.
  if (still_pose_) {
    const auto [m, rad] = pose_distance(pose, *still_pose_);
    if (m > kStillPoseM || rad > kStillPoseRad) still_pose_.reset();
  }
  if (!still_pose_) {
    still_pose_ = pose;
    still_since_ = now;
  }
  const bool still = config_.pose_still_s > 0.0 && now - still_since_ >= config_.pose_still_s;
  if (!centre_ || !(config_.pose_smoothing_s > 0.0) || still) {
    centre_ = pose;
    centre_time_ = now;
    return;
  }
  // Exponential low-pass in host time: poses arrive at an uneven rate over a real link.
  const double a = 1.0 - std::exp(-std::max(0.0, now - centre_time_) / config_.pose_smoothing_s);
  centre_time_ = now;
  msg::HeadPose c = pose;  // FOV and sequence from the newest pose
  c.position = glm::mix(centre_->position, pose.position, static_cast<float>(a));
  const glm::dquat from(centre_->rotation[0], centre_->rotation[1], centre_->rotation[2], centre_->rotation[3]);
  const glm::dquat to(pose.rotation[0], pose.rotation[1], pose.rotation[2], pose.rotation[3]);
  const glm::dquat q = glm::normalize(glm::slerp(glm::normalize(from), glm::normalize(to), a));
  c.rotation = glm::vec4(static_cast<float>(q.w), static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z));
  centre_ = c;
}

HostSession::Motion HostSession::pose_motion() const {
  if (!pose_) return Motion::None;
  if (!selected_pose_) return Motion::Jump;
  const auto [raw_m, raw_rad] = pose_distance(*pose_, *selected_pose_);
  if (raw_m > config_.pose_jump_m || raw_rad > config_.pose_jump_rad) return Motion::Jump;
  const auto [m, rad] = pose_distance(centre_.value_or(*pose_), *selected_pose_);
  return m > config_.pose_epsilon_m || rad > config_.pose_epsilon_rad ? Motion::Drift : Motion::None;
}

msg::SceneInfo HostSession::scene_info(const SceneStore& scene) const {
  msg::SceneInfo info;
  info.epoch = scene.epoch();
  if (!scene.bounds().empty()) {
    info.bounds_min = scene.bounds().min;
    info.bounds_max = scene.bounds().max;
  }
  info.codec = params_;
  info.total_gaussians = scene.appearance_count();
  info.view = config_.view.value_or(room_view(info.bounds_min, info.bounds_max));
  for (const auto& o : scene.objects())
    if (to_underlying(o.id) >= 0 && info.objects.size() < msg::kMaxObjects) info.objects.push_back(object_info(o));
  return info;
}

Expected<std::vector<wire::Message>> HostSession::tick(const SceneStore& scene, double now) {
  std::vector<wire::Message> out;
  if (!accepted_ || closed_ || scene.in_epoch() || to_underlying(scene.epoch()) == 0) return out;
  const Epoch epoch = scene.epoch();
  const bool new_epoch = !sent_epoch_ || to_underlying(epoch) > to_underlying(*sent_epoch_);
  const std::uint64_t acked = last_ack_ ? last_ack_->last_batch_id : 0;
  const bool link_keeps_up = (next_batch_id_ - 1) - acked <= config_.max_unacked_batches;
  const Motion motion = pose_motion();
  const bool moved = motion != Motion::None || query_changed_;
  if (!needs_resync_ && !new_epoch && !(moved && link_keeps_up)) return out;
  // A hierarchy updated in the background is not read until it stands for this epoch: the
  // tick waits (nothing changes here) and a later one selects.
  const bool lod_follows = lod_ && config_.lod_in_background && config_.shared_lod;
  if (lod_follows && !lod_->follow(scene)) return out;

  SelectionRequest req;
  req.budget = capacity_;
  req.client_capacity = capacity_;
  req.query = query_;
  req.rho = query_ ? rho_ : 0.0;
  // A jump selects at the raw pose and restarts the sway centre there; anything else
  // (drift, a new epoch, a query) selects at the sway centre, so a scene update while
  // the user sways does not pick up the sway's current extreme.
  if (motion == Motion::Jump && pose_) {
    centre_ = pose_;
    centre_time_ = now;
  }
  const msg::HeadPose pose = centre_ ? *centre_ : pose_.value_or(msg::HeadPose{});
  if (config_.eligibility && (!eligible_ || eligible_->epoch != scene.epoch())) {
    if (config_.shared_eligible && config_.shared_eligible->rule() == *config_.eligibility) {
      auto e = config_.shared_eligible->at(scene);
      if (!e) return Error{"host session " + std::to_string(client_id_) + ": eligibility: " + e.message()};
      eligible_ = std::move(*e);
    } else {
      auto e = filter_eligible(scene, *config_.eligibility);
      if (!e) return Error{"host session " + std::to_string(client_id_) + ": eligibility: " + e.message()};
      eligible_ = std::make_shared<const EligibleSet>(std::move(*e));
    }
  }
  if (lod_ && !lod_follows) {
    if (Status st = lod_->update(scene, eligible_ ? &*eligible_ : nullptr); !st) {
      ++stats_.lod_fallbacks;
      notices_.push_back("client " + std::to_string(client_id_) + ": " + st.message());
    }
  }
  const ClientPose client_pose = to_client_pose(pose);
  auto sel = lod_ ? lod_->select(selector_, scene, eligible_ ? &*eligible_ : nullptr, client_pose, req)
            : eligible_ ? selector_.select(scene, client_pose, req, *eligible_)
                        : selector_.select(scene, client_pose, req);
  if (!sel) return Error{"host session " + std::to_string(client_id_) + ": selection failed: " + sel.message()};
  if (needs_resync_) differ_.reset();
  // Edit headers: the encoder copies each value edit's record from the differ, so a copy of
  // its Gaussian would only be written to be dropped (58 MB for a joining client's 200k).
  auto batch = lod_ ? differ_.diff_headers(*sel, scene, lod_->records(), lod_->modified())
                    : differ_.diff_headers(*sel, scene);
  if (!batch) return Error{"host session " + std::to_string(client_id_) + ": diff failed: " + batch.message()};
  if (lod_) lod_->clear_modified();
  if (pose_) selected_pose_ = pose;
  const bool had_query_change = query_changed_;
  query_changed_ = false;
  sent_ids_ = sel->ids;
  if (!needs_resync_ && !new_epoch && batch->edits.empty()) return out;

  if (needs_resync_) out.push_back(scene_info(scene));
  // A resync sends the whole surface and object table; a batch of a new epoch what the
  // epochs since the last batch changed; a selection-only batch neither.
  SceneDelta delta = !needs_resync_ && new_epoch ? delta_since_sent(scene, epoch) : SceneDelta{};
  std::vector<wire::Message> patches =
      surface_patches(scene, epoch, needs_resync_ || !delta.complete, std::move(delta.chunks));
  // A resync's surface goes before its batch: when the client applies the resync batch,
  // every chunk the scene holds has arrived (same ordered channel), so whatever else
  // the client holds is stale and goes (SurfaceStage::drop_not_resent).
  if (needs_resync_) {
    for (auto& p : patches) out.push_back(std::move(p));
    patches.clear();
  }
  msg::EditBatchMsg bm;
  bm.epoch = epoch;
  bm.batch_id = next_batch_id_++;
  bm.edit_count = static_cast<std::uint32_t>(batch->edits.size());
  bm.flags = needs_resync_ ? msg::kBatchResync : 0;
  bm.host_time_us = to_us(now);
  // The differ quantised each value edit's record as it sent it: the encoder copies them.
  auto payload = encode_edit_headers(*batch, differ_.params(), differ_.last_sent_records());
  if (!payload) {
    // The differ already counts the batch as sent: start over from an empty client.
    needs_resync_ = true;
    return Error{"host session " + std::to_string(client_id_) + ": " + payload.message()};
  }
  bm.payload = std::move(*payload);
  ++stats_.batches_sent;
  stats_.edits_sent += batch->edits.size();
  stats_.payload_bytes_sent += bm.payload.size();
  events_.batch(now, client_id_, epoch, BatchStage::Available, batch->edits.size());
  events_.batch(now, client_id_, epoch, BatchStage::Sent, batch->edits.size());
  if (had_query_change && sel->query)
    events_.query(now, client_id_, query_id_, QueryStage::DesiredResidency,
                  sel->query->objects.empty() ? kNoObject : sel->query->objects.front().id, sel->object_selected);
  out.push_back(std::move(bm));
  for (auto& p : patches) out.push_back(std::move(p));

  if (needs_resync_) {
    sent_objects_.clear();
    for (const auto& o : scene.objects()) sent_objects_.insert(to_underlying(o.id));
  } else if (delta.objects_changed || !delta.complete) {  // a log that no longer reaches back: assume changed
    msg::ObjectTableUpdate upd;
    upd.epoch = epoch;
    std::set<std::int32_t> now_ids;
    for (const auto& o : scene.objects()) {
      if (to_underlying(o.id) < 0 || upd.upserts.size() >= msg::kMaxObjects) continue;
      upd.upserts.push_back(object_info(o));
      now_ids.insert(to_underlying(o.id));
    }
    for (std::int32_t id : sent_objects_)
      if (!now_ids.count(id)) upd.removed.push_back(ObjectId{id});
    sent_objects_ = std::move(now_ids);
    out.push_back(std::move(upd));
  }
  needs_resync_ = false;
  sent_epoch_ = epoch;
  return out;
}

HostSession::SceneDelta HostSession::delta_since_sent(const SceneStore& scene, Epoch epoch) const {
  SceneDelta d;
  const std::uint64_t from = sent_epoch_ ? to_underlying(*sent_epoch_) + 1 : 1;
  for (std::uint64_t e = from; e <= to_underlying(epoch); ++e) {
    const EpochChanges* ch = scene.changes(Epoch{e});
    if (!ch) {
      d.complete = false;
      break;
    }
    d.objects_changed |= ch->objects_changed;
    d.chunks.insert(d.chunks.end(), ch->chunks_changed.begin(), ch->chunks_changed.end());
  }
  return d;
}

// Surface: every chunk the scene holds when `all`, else `changed` (an empty mesh for a
// chunk the scene dropped removes it).
std::vector<wire::Message> HostSession::surface_patches(const SceneStore& scene, Epoch epoch, bool all,
                                                        std::vector<std::uint32_t> chunks) const {
  if (all) {
    chunks.clear();
    for (const auto& c : scene.surface_chunks()) chunks.push_back(c.chunk_id);
  }
  std::sort(chunks.begin(), chunks.end());
  chunks.erase(std::unique(chunks.begin(), chunks.end()), chunks.end());
  std::vector<wire::Message> out;
  const auto& held = scene.surface_chunks();
  for (std::uint32_t id : chunks) {
    msg::SurfacePatch patch;
    patch.epoch = epoch;
    patch.chunk_id = id;
    auto it = std::lower_bound(held.begin(), held.end(), id,
                               [](const SurfaceChunk& c, std::uint32_t v) { return c.chunk_id < v; });
    if (it != held.end() && it->chunk_id == id) patch.mesh = it->mesh;  // absent: empty mesh removes it
    out.push_back(std::move(patch));
  }
  return out;
}

std::uint64_t HostSession::sent_checksum() const {
  std::uint64_t sum = 0;
  differ_.for_each_sent([&sum](const Gaussian& g) { sum += record_hash(g.id, g); });
  return sum;
}

}  // namespace gauss
