#include "gauss/engine/client_state.h"

#include <algorithm>

#include "gauss/engine/codec.h"

namespace gauss {

Expected<ClientState> ClientState::create(std::uint32_t client_index, ClientConfig config) {
  auto slots = SlotTable::create(config.capacity);
  if (!slots) return Error{"client " + config.name + ": " + slots.message()};
  return ClientState(client_index, std::move(config), std::move(*slots));
}

ClientState::ClientState(std::uint32_t client_index, ClientConfig config, SlotTable slots)
    : client_index_(client_index),
      config_(std::move(config)),
      mutex_(std::make_unique<std::mutex>()),
      desired_(config_.capacity, config_.arrival_slack),
      slots_(std::move(slots)),
      publisher_([this] {
        // The publisher's range estimate uses the same gap the uploads are merged with.
        PublisherConfig p = config_.publisher;
        p.range_gap = config_.range_merge_gap;
        return p;
      }()),
      next_query_id_(std::make_unique<std::atomic<std::uint32_t>>(1u)) {}

msg::Hello ClientState::hello() const {
  msg::Hello h;
  h.slot_capacity = config_.capacity;
  h.access_token = config_.access_token;
  h.client_name = config_.name.substr(0, msg::kMaxLabelBytes);
  return h;
}

Status ClientState::reject(std::string reason) {
  ++stats_.rejected_messages;
  stats_.last_rejection = reason;
  return Error{"client " + config_.name + ": " + std::move(reason)};
}

Status ClientState::on_batch(const msg::EditBatchMsg& b, std::optional<DecodedBatch>& decoded, double now) {
  if (!codec_) return reject("edit batch " + std::to_string(b.batch_id) + " before SceneInfo (no codec parameters)");
  if (b.batch_id <= last_batch_id_)
    return reject("edit batch " + std::to_string(b.batch_id) + " not newer than batch " + std::to_string(last_batch_id_));
  // Decoded before the lock was taken, unless the codec changed in between.
  if (!decoded || !(decoded->codec == *codec_)) decoded = DecodedBatch{*codec_, decode_edit_batch(b.payload, *codec_)};
  auto& batch = decoded->batch;
  if (!batch) return reject("edit batch " + std::to_string(b.batch_id) + ": " + batch.message());
  if (batch->epoch != b.epoch || batch->edits.size() != b.edit_count)
    return reject("edit batch " + std::to_string(b.batch_id) + ": payload says epoch " +
                  std::to_string(to_underlying(batch->epoch)) + " with " + std::to_string(batch->edits.size()) +
                  " edits, header says epoch " + std::to_string(to_underlying(b.epoch)) + " with " +
                  std::to_string(b.edit_count));
  events_.batch(now, client_index_, b.epoch, BatchStage::Received, b.edit_count);
  const bool resync = (b.flags & msg::kBatchResync) != 0;
  auto rep = resync ? desired_.apply_resync(*batch, now) : desired_.apply(*batch, now);
  if (!rep) return reject("edit batch " + std::to_string(b.batch_id) + ": " + rep.message());
  last_batch_id_ = b.batch_id;
  ++stats_.batches;
  stats_.edits_received += b.edit_count;
  if (resync) {
    ++stats_.resyncs;
    // The resync's surface arrived before its batch (HostSession::tick): what it did not
    // resend, the scene no longer holds.
    surface_.drop_not_resent(b.epoch);
  }
  events_.batch(now, client_index_, b.epoch, BatchStage::Desired, rep->accepted);
  events_.batch(now, client_index_, b.epoch, BatchStage::Queued, rep->newly_pending);
  unpublished_.push_back({b.batch_id, b.epoch, b.edit_count, false});
  if (query_track_ && query_track_->batch_after == 0) query_track_->batch_after = b.batch_id;
  const auto pub = desired_.published_epoch();
  outgoing_.push_back(msg::Ack{b.batch_id, b.epoch, pub.value_or(Epoch{0})});
  if (rep->rejected > 0) {
    // The batch is applied minus its bad edits; report them without failing the stream.
    ++stats_.rejected_messages;
    stats_.last_rejection = "edit batch " + std::to_string(b.batch_id) + ": " + std::to_string(rep->rejected) +
                            " edits rejected, first: " + rep->first_rejection;
  }
  return Ok{};
}

Status ClientState::on_message(const wire::Message& m, double now) {
  // An edit batch is decoded before the lock is taken: the display thread takes that lock
  // every frame, and decoding a teleport's batch takes milliseconds. The codec is read
  // under the lock and compared again once it is held.
  std::optional<DecodedBatch> decoded;
  if (const auto* b = std::get_if<msg::EditBatchMsg>(&m)) {
    std::optional<CodecParams> codec;
    {
      std::lock_guard<std::mutex> lock(*mutex_);
      codec = codec_;
    }
    if (codec) decoded = DecodedBatch{*codec, decode_edit_batch(b->payload, *codec)};
  }
  std::lock_guard<std::mutex> lock(*mutex_);
  const msg::MessageType type = wire::type_of(m);
  if (msg::direction_of(type) != msg::Direction::HostToClient)
    return reject(std::string("host sent client-only message ") + msg::to_string(type));
  if (const auto* w = std::get_if<msg::Welcome>(&m)) {
    if (w->slot_capacity == 0 || w->slot_capacity > config_.capacity)
      return reject("Welcome grants " + std::to_string(w->slot_capacity) + " slots, more than the " +
                    std::to_string(config_.capacity) + " asked for");
    welcomed_ = true;
    last_batch_id_ = 0;  // batch ids are per connection
    if (host_session_ && *host_session_ != w->session_id) {
      // The host restarted: epochs are per host session, and the new one counts from its
      // start. Without this its resync (an older epoch number) would be refused and the
      // client would keep the old session's state while the host believes otherwise.
      desired_.restart_epochs();
      surface_.restart_epochs();
      unpublished_.clear();         // the old session's batches
      acked_published_.reset();     // its epochs, too
    }
    host_session_ = w->session_id;
    // The host starts from an empty view of this client: resend pose and query.
    if (last_pose_) {
      msg::HeadPose p = *last_pose_;
      p.sequence = next_pose_seq_++;
      outgoing_.push_back(p);
    }
    if (last_query_) {
      msg::Query q = *last_query_;
      q.query_id = reserve_query_id();
      outgoing_.push_back(q);
    }
    return Ok{};
  }
  if (std::holds_alternative<msg::Refuse>(m)) {
    welcomed_ = false;
    return reject("host refused the connection: " + std::get<msg::Refuse>(m).detail);
  }
  if (!welcomed_) return reject(std::string(msg::to_string(type)) + " before the Welcome");
  if (const auto* info = std::get_if<msg::SceneInfo>(&m)) {
    Status v = validate_codec_params(info->codec);
    if (!v) return reject("SceneInfo: " + v.message());
    codec_ = info->codec;
    view_ = info->view;
    objects_.clear();
    for (const auto& o : info->objects) objects_[to_underlying(o.id)] = o;
    return Ok{};
  }
  if (const auto* b = std::get_if<msg::EditBatchMsg>(&m)) return on_batch(*b, decoded, now);
  if (const auto* p = std::get_if<msg::SurfacePatch>(&m)) {
    StagedChunk c{p->chunk_id, p->epoch, p->mesh};
    Status s = surface_.offer(std::move(c));
    if (!s) return reject(s.message());
    return Ok{};
  }
  if (const auto* u = std::get_if<msg::ObjectTableUpdate>(&m)) {
    for (const auto& o : u->upserts) objects_[to_underlying(o.id)] = o;
    for (ObjectId id : u->removed) objects_.erase(to_underlying(id));
    return Ok{};
  }
  if (const auto* r = std::get_if<msg::QueryReply>(&m)) {
    if (r->status == msg::QueryStatus::Resolved) {
      QueryTrack t;
      t.query_id = r->query_id;
      t.targets = r->targets;
      t.target_gaussians = r->target_gaussians;
      std::sort(t.targets.begin(), t.targets.end());
      // The residency the query starts from is counted now, before any publication: the
      // reply and the first batch it causes may arrive before the same frame, and a count
      // taken after that frame's publication would already include the new content.
      t.initial = count_resident(t.targets);
      // The client learns the targets now: the stage the host logs as Target, on this clock.
      events_.query(now, client_index_, t.query_id, QueryStage::Target, t.targets.empty() ? kNoObject : t.targets.front(),
                    t.target_gaussians);
      query_track_ = std::move(t);
    } else if (r->status == msg::QueryStatus::Cleared) {
      query_track_.reset();
    }
    return Ok{};
  }
  return Ok{};
}

std::uint64_t ClientState::count_resident(std::span<const ObjectId> targets) const {
  std::uint64_t n = 0;
  for (std::uint32_t s = 0; s < slots_.capacity(); ++s) {
    GaussianId id{0};
    if (slots_.occupant(SlotIndex{s}, id) &&
        std::binary_search(targets.begin(), targets.end(), slots_.records()[s].object))
      ++n;
  }
  return n;
}

void ClientState::track_query(double now, std::uint64_t frame_index, bool rendered, bool slots_written,
                              std::uint64_t shown_step) {
  if (!query_track_) return;
  QueryTrack& q = *query_track_;
  const ObjectId first = q.targets.empty() ? kNoObject : q.targets.front();
  if (!rendered && q.first_step == 0) q.first_step = step_;
  if (rendered) {
    // The tint follows the targets a frame() handed out: a rendered frame showing an
    // earlier step (a client publishing ahead of its display) does not show it yet.
    if (!q.highlight_shown && q.first_step != 0 && q.first_step <= shown_step) {
      q.highlight_shown = true;
      events_.query(now, client_index_, q.query_id, QueryStage::Highlight, first, 0, frame_index);
    }
    return;
  }
  if (q.converged) return;
  if (!q.initial_reported) {
    q.initial_reported = true;
    events_.query(now, client_index_, q.query_id, QueryStage::InitialResidency, first, q.initial, frame_index);
  }
  // Target residency by a scan of the published slots: only while a query converges,
  // and only after a frame that wrote slots (a query waiting for its batch must not
  // cost an O(M) scan on every idle frame).
  auto is_target = [&q](ObjectId o) { return std::binary_search(q.targets.begin(), q.targets.end(), o); };
  if (!q.resident || slots_written) q.resident = count_resident(q.targets);
  const std::uint64_t resident = *q.resident;
  if (!q.first_additional && resident > q.initial) {
    q.first_additional = true;
    events_.query(now, client_index_, q.query_id, QueryStage::FirstAdditional, first, resident, frame_index);
  }
  // Converged: a batch after the resolution arrived and every desired target member is published.
  if (q.batch_after != 0) {
    bool target_pending = false;
    for (std::uint32_t idx : desired_.pending()) target_pending |= is_target(desired_.entry(idx).value.object);
    if (!target_pending) {
      q.converged = true;
      events_.query(now, client_index_, q.query_id, QueryStage::Converged, first, resident, frame_index);
    }
  }
}

Expected<FrameResult> ClientState::frame(const ViewState& view, double now, std::uint64_t frame_index) {
  std::lock_guard<std::mutex> lock(*mutex_);
  FrameResult out;
  out.step = ++step_;
  auto rep = publisher_.publish(desired_, slots_, view, now);
  if (!rep) {
    if (query_track_) query_track_->resident.reset();  // it may have written slots before failing
    return Error{"client " + config_.name + ": " + rep.message()};
  }
  out.publish = *rep;
  out.published_epoch = desired_.published_epoch();
  out.surface_committed = surface_.commit(out.published_epoch);
  out.surface_epoch = surface_.committed_epoch();
  out.ranges = slots_.take_dirty_ranges(config_.range_merge_gap);
  // A batch is published once nothing of its epoch or older is pending.
  const auto oldest = desired_.oldest_pending_epoch();
  for (auto& b : unpublished_) {
    if (!b.published && (!oldest || to_underlying(*oldest) > to_underlying(b.epoch))) {
      b.published = true;
      b.published_step = out.step;
      events_.batch(now, client_index_, b.epoch, BatchStage::Published, b.edits, frame_index);
    }
  }
  if (out.published_epoch && (!acked_published_ || *acked_published_ != *out.published_epoch)) {
    acked_published_ = out.published_epoch;
    outgoing_.push_back(msg::Ack{last_batch_id_, desired_.received_epoch().value_or(Epoch{0}), *out.published_epoch});
  }
  track_query(now, frame_index, false, out.publish.slot_writes() > 0, out.step);
  return out;
}

void ClientState::frame_rendered(double now, std::uint64_t frame_index, std::uint64_t shown_step) {
  std::lock_guard<std::mutex> lock(*mutex_);
  std::erase_if(unpublished_, [&](const PendingBatch& b) {
    if (!b.published || b.published_step > shown_step) return false;
    events_.batch(now, client_index_, b.epoch, BatchStage::FirstFrame, b.edits, frame_index);
    return true;
  });
  track_query(now, frame_index, true, false, shown_step);
}

void ClientState::report_frame_cost(double seconds) {
  std::lock_guard<std::mutex> lock(*mutex_);
  publisher_.report_frame_cost(seconds);
}

void ClientState::set_publish_mode(PublishMode mode) {
  std::lock_guard<std::mutex> lock(*mutex_);
  publisher_.set_mode(mode);
}

void ClientState::set_display_period(double seconds) {
  std::lock_guard<std::mutex> lock(*mutex_);
  publisher_.set_display_period(seconds);
}

std::vector<wire::Message> ClientState::take_outgoing() {
  std::lock_guard<std::mutex> lock(*mutex_);
  std::vector<wire::Message> out;
  out.swap(outgoing_);
  return out;
}

void ClientState::send_pose(msg::HeadPose pose) {
  std::lock_guard<std::mutex> lock(*mutex_);
  pose.sequence = next_pose_seq_++;
  last_pose_ = pose;
  if (welcomed_) outgoing_.push_back(pose);
}

std::uint32_t ClientState::reserve_query_id() noexcept { return next_query_id_->fetch_add(1u); }

std::uint32_t ClientState::send_query(msg::Query query) {
  query.query_id = reserve_query_id();
  const std::uint32_t id = query.query_id;
  send_reserved_query(std::move(query));
  return id;
}

void ClientState::send_reserved_query(msg::Query query) {
  std::lock_guard<std::mutex> lock(*mutex_);
  last_query_ = query.kind == msg::QueryKind::Clear ? std::nullopt : std::optional<msg::Query>(query);
  if (welcomed_) outgoing_.push_back(query);
}

void ClientState::on_disconnect() {
  std::lock_guard<std::mutex> lock(*mutex_);
  welcomed_ = false;
  outgoing_.clear();  // acks and controls of the old connection mean nothing to the next
}

std::uint64_t ClientState::published_checksum() const {
  std::uint64_t sum = 0;
  for (std::uint32_t s = 0; s < slots_.capacity(); ++s) {
    GaussianId id{0};
    if (slots_.occupant(SlotIndex{s}, id)) sum += record_hash(id, slots_.records()[s]);
  }
  return sum;
}

Status ClientState::check() const {
  if (Status s = slots_.check(); !s) return s;
  if (Status s = desired_.check(); !s) return s;
  if (slots_.size() > config_.capacity)
    return Error{"client " + config_.name + ": " + std::to_string(slots_.size()) + " published exceeds M"};
  if (slots_.size() != desired_.published_count())
    return Error{"client " + config_.name + ": slot table holds " + std::to_string(slots_.size()) +
                 ", desired state believes " + std::to_string(desired_.published_count())};
  const auto surf = surface_.committed_epoch();
  if (surf) {
    const auto gauss_epoch = desired_.published_epoch();
    if (!gauss_epoch || to_underlying(*surf) > to_underlying(*gauss_epoch))
      return Error{"client " + config_.name + ": epoch barrier broken: surface at epoch " +
                   std::to_string(to_underlying(*surf)) + " ahead of the published Gaussians"};
  }
  return Ok{};
}

}  // namespace gauss
