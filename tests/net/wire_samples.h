#pragma once
// Valid sample messages of every type (edge cases included), shared by the wire
// round-trip tests and the fuzz-corpus writer (test_wire_corpus.cpp).
#include <cmath>
#include <string>
#include <vector>

#include "gauss/engine/codec.h"
#include "gauss/engine/wire.h"

namespace gauss::test {

inline Gaussian sample_gaussian(std::uint64_t id, float x) {
  Gaussian g;
  g.id = GaussianId{id};
  g.position = {x, 0.5f, -1.0f};
  g.log_scale = {-3.0f, -3.5f, -4.0f};
  g.rotation = {1.0f, 0.0f, 0.0f, 0.0f};
  g.opacity_logit = 1.5f;
  g.sh_dc = {0.2f, -0.1f, 0.4f};
  g.object = ObjectId{static_cast<std::int32_t>(id % 3)};
  g.support = 7;
  return g;
}

inline msg::ObjectInfo sample_object(std::int32_t id, const std::string& label) {
  msg::ObjectInfo o;
  o.id = ObjectId{id};
  o.label = label;
  o.centroid = {0.5f, 1.0f, 2.0f};
  o.extent_min = {0.0f, 0.5f, 1.5f};
  o.extent_max = {1.0f, 1.5f, 2.5f};
  o.quality = 0.75f;
  o.member_count = 1234;
  return o;
}

inline msg::SceneInfo sample_scene_info() {
  msg::SceneInfo s;
  s.epoch = Epoch{3};
  s.bounds_min = {-2.0f, 0.0f, -3.0f};
  s.bounds_max = {2.0f, 2.5f, 3.0f};
  s.codec.box = {{-2.5f, -0.5f, -3.5f}, {2.5f, 3.0f, 3.5f}};
  s.codec.sh_degree = 1;
  s.total_gaussians = 100000;
  s.objects = {sample_object(0, "chair"), sample_object(1, "table"), sample_object(7, "")};
  s.view.up = {0.0f, -1.0f, 0.0f};
  s.view.subject_min = {-1.5f, 0.25f, -2.0f};
  s.view.subject_max = {1.5f, 2.0f, 2.5f};
  s.view.flags = msg::kViewSeenFrom;
  s.view.seen_from = {0.0f, 1.5f, -4.0f};
  return s;
}

inline msg::EditBatchMsg sample_edit_batch(const CodecParams& params) {
  EditBatch b;
  b.epoch = Epoch{4};
  b.edits.push_back({EditKind::Insert, GaussianId{10}, GaussianId{0}, sample_gaussian(10, 0.1f)});
  b.edits.push_back({EditKind::Update, GaussianId{11}, GaussianId{0}, sample_gaussian(11, 0.2f)});
  b.edits.push_back({EditKind::Remove, GaussianId{12}, GaussianId{0}, Gaussian{}});
  b.edits.push_back({EditKind::Replace, GaussianId{14}, GaussianId{13}, sample_gaussian(14, 0.3f)});
  msg::EditBatchMsg m;
  m.epoch = b.epoch;
  m.batch_id = 9;
  m.edit_count = static_cast<std::uint32_t>(b.edits.size());
  m.flags = 0;
  m.host_time_us = 123456789;
  m.payload = encode_edit_batch(b, params);
  return m;
}

inline msg::SurfacePatch sample_surface_patch() {
  msg::SurfacePatch p;
  p.epoch = Epoch{4};
  p.chunk_id = 0x0102030405ull;
  for (int i = 0; i < 6; ++i) {
    p.mesh.positions.push_back({0.1f * float(i), 0.0f, 1.0f - 0.05f * float(i)});
    p.mesh.colors.push_back({static_cast<std::uint8_t>(40 * i), 200, 17});
  }
  p.mesh.indices = {0, 1, 2, 2, 3, 4, 4, 5, 0};
  return p;
}

// Every type at least once; some types twice to cover optional/empty fields.
inline std::vector<wire::Message> sample_messages() {
  std::vector<wire::Message> out;
  msg::Hello hello;
  hello.slot_capacity = 200000;
  hello.access_token = "s3cret";
  hello.client_name = "quest-1";
  out.push_back(hello);
  msg::Hello bare;
  bare.slot_capacity = 1;
  out.push_back(bare);
  out.push_back(msg::Welcome{msg::kProtocolVersion, 0xDEADBEEFCAFEull, 2, 200000});
  out.push_back(msg::Refuse{msg::RefuseReason::BadToken, msg::kProtocolVersion, "access token required"});
  const msg::SceneInfo scene = sample_scene_info();
  out.push_back(scene);
  out.push_back(sample_edit_batch(scene.codec));
  msg::EditBatchMsg resync;
  resync.epoch = Epoch{5};
  resync.batch_id = 10;
  resync.flags = msg::kBatchResync;
  resync.payload = encode_edit_batch(EditBatch{Epoch{5}, {}}, scene.codec);
  out.push_back(resync);
  out.push_back(sample_surface_patch());
  msg::SurfacePatch removed_chunk;
  removed_chunk.epoch = Epoch{6};
  removed_chunk.chunk_id = 3;
  out.push_back(removed_chunk);
  msg::ObjectTableUpdate upd;
  upd.epoch = Epoch{6};
  upd.upserts = {sample_object(2, "plant")};
  upd.removed = {ObjectId{1}, ObjectId{5}};
  out.push_back(upd);
  msg::HeadPose pose;
  pose.sequence = 77;
  pose.client_time_us = 5000000;
  pose.position = {0.1f, -1.6f, 0.3f};
  pose.rotation = {std::sqrt(0.5f), 0.0f, std::sqrt(0.5f), 0.0f};
  pose.tan_half_fov_x = 1.2f;
  pose.tan_half_fov_y = 0.9f;
  out.push_back(pose);
  msg::Query q;
  q.query_id = 1;
  q.kind = msg::QueryKind::ClassText;
  q.text = "chair";
  q.rho = 0.6f;
  out.push_back(q);
  msg::Query qi;
  qi.query_id = 2;
  qi.kind = msg::QueryKind::Instance;
  qi.instance = ObjectId{7};
  qi.rho = 1.0f;
  out.push_back(qi);
  msg::Query clear;
  clear.query_id = 3;
  out.push_back(clear);
  msg::QueryReply reply;
  reply.query_id = 1;
  reply.status = msg::QueryStatus::Resolved;
  reply.epoch = Epoch{6};
  reply.targets = {ObjectId{0}, ObjectId{4}};
  reply.target_gaussians = 5321;
  out.push_back(reply);
  msg::QueryReply rejected;
  rejected.query_id = 9;
  rejected.status = msg::QueryStatus::Rejected;
  rejected.reason = "query rate limit: 20 per second";
  out.push_back(rejected);
  out.push_back(msg::Ack{10, Epoch{6}, Epoch{5}});
  msg::ClientStats stats;
  stats.client_time_us = 7000000;
  stats.frames = 500;
  stats.resident = 150000;
  stats.desired = 160000;
  stats.pending_edits = 10000;
  stats.capacity = 200000;
  stats.frame_ms = 11.1f;
  stats.slack_ms = -0.5f;
  stats.rejected_messages = 2;
  out.push_back(stats);
  msg::Challenge challenge;
  for (std::size_t k = 0; k < challenge.nonce.size(); ++k) challenge.nonce[k] = static_cast<std::uint8_t>(7 * k + 1);
  challenge.flags = msg::kChallengeEncrypt;
  // CPace messages: 0x20, a 32-byte point (any bytes: the codec leaves judging it to
  // net/), 0x00.
  auto pake = [](std::uint8_t seed) {
    msg::PakeMessage m{};
    m.front() = static_cast<std::uint8_t>(msg::kPakePointBytes);
    for (std::size_t k = 1; k + 1 < m.size(); ++k) m[k] = static_cast<std::uint8_t>(seed + 5 * k);
    return m;
  };
  challenge.offers.push_back(msg::AuthOffer{msg::AuthSecret::AccessToken, pake(11)});
  challenge.offers.push_back(msg::AuthOffer{msg::AuthSecret::PairingCode, pake(99)});
  out.push_back(challenge);
  msg::AuthProof proof;
  proof.secret = msg::AuthSecret::PairingCode;
  proof.pake = pake(42);
  for (std::size_t k = 0; k < proof.tag.size(); ++k) proof.tag[k] = static_cast<std::uint8_t>(255 - 3 * k);
  out.push_back(proof);
  msg::AuthConfirm confirm;
  for (std::size_t k = 0; k < confirm.tag.size(); ++k) confirm.tag[k] = static_cast<std::uint8_t>(3 * k + 1);
  out.push_back(confirm);
  return out;
}

}  // namespace gauss::test
