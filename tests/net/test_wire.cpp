// Wire schema round trips and hostile input: every message type encodes and decodes
// back exactly; truncated, oversized, forged and out-of-range input is refused with
// an error that names the field.
#include <cstring>
#include <limits>
#include <set>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include "gauss/engine/codec.h"
#include "gauss/engine/wire.h"
#include "wire_samples.h"

namespace gauss {
namespace {

std::vector<std::uint8_t> frame_of(const wire::Message& m) {
  auto e = wire::encode(m);
  EXPECT_TRUE(e.ok()) << (e.ok() ? "" : e.message());
  return e.ok() ? e.value() : std::vector<std::uint8_t>{};
}

void put_u32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
}

TEST(Wire, EveryTypeRoundTripsExactly) {
  std::set<std::uint16_t> seen;
  for (const auto& m : test::sample_messages()) {
    const auto bytes = frame_of(m);
    ASSERT_GE(bytes.size(), wire::kHeaderBytes);
    auto header = wire::decode_header(bytes);
    ASSERT_TRUE(header.ok()) << header.message();
    EXPECT_EQ(header->type, wire::type_of(m));
    EXPECT_EQ(header->body_length, bytes.size() - wire::kHeaderBytes);
    auto back = wire::decode(bytes);
    ASSERT_TRUE(back.ok()) << msg::to_string(wire::type_of(m)) << ": " << back.message();
    EXPECT_TRUE(back.value() == m) << msg::to_string(wire::type_of(m));
    // Canonical: encoding the decoded message gives the same bytes.
    EXPECT_EQ(frame_of(back.value()), bytes) << msg::to_string(wire::type_of(m));
    seen.insert(static_cast<std::uint16_t>(wire::type_of(m)));
  }
  EXPECT_EQ(seen.size(), std::size_t{msg::kLastMessageType - msg::kFirstMessageType + 1u})
      << "a message type has no sample";
}

TEST(Wire, EncodeAppendConcatenatesAndKeepsBufferOnFailure) {
  std::vector<std::uint8_t> buf;
  const auto samples = test::sample_messages();
  for (const auto& m : samples) ASSERT_TRUE(wire::encode_append(m, buf).ok());
  std::size_t at = 0, count = 0;
  while (at < buf.size()) {
    ASSERT_GE(buf.size() - at, wire::kHeaderBytes);
    std::uint32_t len = 0;
    std::memcpy(&len, buf.data() + at + 4, 4);  // test host is little-endian like the wire
    const std::span<const std::uint8_t> frame(buf.data() + at, wire::kHeaderBytes + len);
    auto d = wire::decode(frame);
    ASSERT_TRUE(d.ok()) << d.message();
    EXPECT_TRUE(d.value() == samples[count]);
    at += frame.size();
    ++count;
  }
  EXPECT_EQ(count, samples.size());

  const auto before = buf;
  msg::Hello bad;
  bad.slot_capacity = 0;
  auto s = wire::encode_append(bad, buf);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("slot_capacity"), std::string::npos) << s.message();
  EXPECT_EQ(buf, before);
}

TEST(Wire, EveryTruncationAndTrailingByteIsRejected) {
  for (const auto& m : test::sample_messages()) {
    const auto bytes = frame_of(m);
    for (std::size_t n = 0; n < bytes.size(); ++n) {
      auto d = wire::decode(std::span(bytes.data(), n));
      EXPECT_FALSE(d.ok()) << msg::to_string(wire::type_of(m)) << " prefix of " << n << " bytes decoded";
    }
    // A body cut short but with the header patched to match must fail in the body decoder.
    if (bytes.size() > wire::kHeaderBytes) {
      auto cut = bytes;
      cut.pop_back();
      put_u32(cut, 4, static_cast<std::uint32_t>(cut.size() - wire::kHeaderBytes));
      EXPECT_FALSE(wire::decode(cut).ok()) << msg::to_string(wire::type_of(m));
    }
    auto longer = bytes;
    longer.push_back(0);
    put_u32(longer, 4, static_cast<std::uint32_t>(longer.size() - wire::kHeaderBytes));
    auto d = wire::decode(longer);
    ASSERT_FALSE(d.ok()) << msg::to_string(wire::type_of(m));
    EXPECT_NE(d.message().find("trailing"), std::string::npos) << d.message();
  }
}

TEST(Wire, BadHeadersAreRejectedWithReason) {
  auto bytes = frame_of(msg::Ack{1, Epoch{2}, Epoch{1}});
  for (std::uint16_t type : {std::uint16_t{0}, std::uint16_t{msg::kLastMessageType + 1}, std::uint16_t{0xFFFF}}) {
    auto b = bytes;
    b[0] = static_cast<std::uint8_t>(type);
    b[1] = static_cast<std::uint8_t>(type >> 8);
    auto d = wire::decode(b);
    ASSERT_FALSE(d.ok());
    EXPECT_NE(d.message().find("unknown message type"), std::string::npos) << d.message();
  }
  auto reserved = bytes;
  reserved[2] = 1;
  EXPECT_FALSE(wire::decode(reserved).ok());
  // A header claiming a huge body is refused from the header alone.
  auto huge = bytes;
  put_u32(huge, 4, 0xFFFFFFF0u);
  auto d = wire::decode(huge);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.message().find("exceeds the message limit"), std::string::npos) << d.message();
}

TEST(Wire, ForgedCountsNeverAllocateBeyondThePayload) {
  msg::Hello h;
  h.slot_capacity = 5;
  auto b = frame_of(h);
  put_u32(b, 16, 0xFFFFFFFFu);  // access_token length
  auto d = wire::decode(b);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.message().find("access_token"), std::string::npos) << d.message();

  msg::ObjectTableUpdate u;
  u.epoch = Epoch{1};
  auto ub = frame_of(u);
  put_u32(ub, 16, 1u << 16);  // upserts count within the schema bound but without bytes
  d = wire::decode(ub);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.message().find("upserts"), std::string::npos) << d.message();
  put_u32(ub, 16, (1u << 16) + 1);  // beyond the schema bound
  d = wire::decode(ub);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.message().find("exceeds limit"), std::string::npos) << d.message();
}

TEST(Wire, CapacityZeroAndBillionAreRejected) {
  msg::Hello h;
  h.slot_capacity = 1000;
  auto b = frame_of(h);
  for (std::uint32_t cap : {0u, 1000000000u, gauss::kMaxSlotCapacity + 1}) {
    put_u32(b, 12, cap);
    auto d = wire::decode(b);
    ASSERT_FALSE(d.ok()) << cap;
    EXPECT_NE(d.message().find("slot_capacity"), std::string::npos) << d.message();
    h.slot_capacity = cap;
    EXPECT_FALSE(wire::encode(h).ok()) << cap;
  }
  put_u32(b, 12, gauss::kMaxSlotCapacity);
  EXPECT_TRUE(wire::decode(b).ok());
}

TEST(Wire, NonFiniteAndOutOfRangeFieldsAreRejected) {
  msg::HeadPose p;
  p.position.x = std::numeric_limits<float>::quiet_NaN();
  EXPECT_FALSE(wire::encode(p).ok());
  p.position.x = 0.0f;
  auto b = frame_of(p);
  const float inf = std::numeric_limits<float>::infinity();
  std::uint32_t bits = 0;
  std::memcpy(&bits, &inf, 4);
  put_u32(b, 8 + 12, bits);  // position.x after sequence + client_time_us
  auto d = wire::decode(b);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.message().find("position"), std::string::npos) << d.message();
  EXPECT_NE(d.message().find("byte 12"), std::string::npos) << d.message();

  p.rotation = {2.0f, 0.0f, 0.0f, 0.0f};
  EXPECT_FALSE(wire::encode(p).ok());

  msg::Query q;
  q.kind = msg::QueryKind::ClassText;
  q.text = "chair";
  q.rho = 1.5f;
  EXPECT_FALSE(wire::encode(q).ok());
  q.rho = 0.5f;
  q.text.clear();
  EXPECT_FALSE(wire::encode(q).ok());
  msg::Query clear;
  clear.text = "x";
  EXPECT_FALSE(wire::encode(clear).ok());
  auto qb = frame_of(msg::Query{1, msg::QueryKind::Instance, "", ObjectId{3}, 0.5f});
  qb[8 + 4] = 9;  // kind
  EXPECT_FALSE(wire::decode(qb).ok());

  msg::Ack a{1, Epoch{3}, Epoch{4}};
  EXPECT_FALSE(wire::encode(a).ok());

  msg::EditBatchMsg e;
  e.flags = 0x80;
  EXPECT_FALSE(wire::encode(e).ok());

  msg::SceneInfo s = test::sample_scene_info();
  s.codec.sh_degree = 4;
  EXPECT_FALSE(wire::encode(s).ok());
  s = test::sample_scene_info();
  s.objects.push_back(s.objects.front());
  auto se = wire::encode(s);
  ASSERT_FALSE(se.ok());
  EXPECT_NE(se.message().find("appears twice"), std::string::npos) << se.message();

  msg::ObjectTableUpdate u;
  u.upserts = {test::sample_object(4, "lamp")};
  u.removed = {ObjectId{4}};
  EXPECT_FALSE(wire::encode(u).ok());
  msg::ClientStats cs;
  cs.capacity = 10;
  cs.resident = 11;
  EXPECT_FALSE(wire::encode(cs).ok());
}

TEST(Wire, SceneInfoViewIsChecked) {
  auto refused = [](msg::SceneView v, const char* field) {
    msg::SceneInfo s = test::sample_scene_info();
    s.view = v;
    auto e = wire::encode(s);
    ASSERT_FALSE(e.ok()) << field;
    EXPECT_NE(e.message().find(field), std::string::npos) << e.message();
  };
  const msg::SceneView good = test::sample_scene_info().view;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  msg::SceneView v = good;
  v.up = {0.0f, 0.0f, 0.0f};
  refused(v, "view.up");
  v.up = {0.0f, 2.0f, 0.0f};
  refused(v, "view.up");
  v.up = {nan, 1.0f, 0.0f};
  refused(v, "view.up");
  v = good;
  v.subject_max.z = std::numeric_limits<float>::infinity();
  refused(v, "view.subject");
  v = good;
  v.subject_min.x = 2.0f;  // above subject_max.x
  refused(v, "view.subject_min");
  v = good;
  v.flags = 0x80;
  refused(v, "view.flags");
  v = good;
  v.seen_from.y = nan;
  refused(v, "view.seen_from");
  // A unit up within rounding passes: a host normalises in double and sends floats.
  v = good;
  v.up = glm::normalize(glm::vec3(0.1f, -0.99f, 0.05f));
  msg::SceneInfo ok = test::sample_scene_info();
  ok.view = v;
  EXPECT_TRUE(wire::encode(ok).ok());

  // The decoder checks what arrives: the flags byte (13th from the end) with an unknown bit.
  auto b = frame_of(test::sample_scene_info());
  b[b.size() - 13] |= 0x40;
  auto d = wire::decode(b);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.message().find("view.flags"), std::string::npos) << d.message();
}

TEST(Wire, SurfacePatchChecksMeshAndCompressedFrame) {
  msg::SurfacePatch p = test::sample_surface_patch();
  p.mesh.indices.back() = 6;  // == vertex count
  auto e = wire::encode(p);
  ASSERT_FALSE(e.ok());
  EXPECT_NE(e.message().find("mesh.indices[8]"), std::string::npos) << e.message();
  p = test::sample_surface_patch();
  p.mesh.colors.pop_back();
  EXPECT_FALSE(wire::encode(p).ok());

  // Header counts that disagree with the zstd frame's declared size are refused
  // before decompression (vertex_count lives at body offset 16).
  auto b = frame_of(test::sample_surface_patch());
  put_u32(b, 8 + 16, 1u << 20);
  auto d = wire::decode(b);
  ASSERT_FALSE(d.ok());
  EXPECT_NE(d.message().find("declares"), std::string::npos) << d.message();
  // Garbage instead of a zstd frame.
  b = frame_of(test::sample_surface_patch());
  for (std::size_t i = 8 + 28; i < b.size(); ++i) b[i] = 0xA5;
  EXPECT_FALSE(wire::decode(b).ok());
}

TEST(Wire, EditBatchPayloadIsTheCodecOutput) {
  const auto scene = test::sample_scene_info();
  const auto m = test::sample_edit_batch(scene.codec);
  auto d = wire::decode(frame_of(m));
  ASSERT_TRUE(d.ok()) << d.message();
  const auto& got = std::get<msg::EditBatchMsg>(d.value());
  auto batch = decode_edit_batch(got.payload, scene.codec);
  ASSERT_TRUE(batch.ok()) << batch.message();
  EXPECT_EQ(batch->epoch, m.epoch);
  EXPECT_EQ(batch->edits.size(), m.edit_count);
}

// A seeded mutation sweep (the CI-sized cousin of the libFuzzer targets): random
// byte flips, insertions and cuts of every sample frame. Whatever decodes must
// re-encode and decode to the same message; nothing may crash (ASan/UBSan builds).
TEST(Wire, SeededMutationsNeverBreakTheRoundTrip) {
  std::uint64_t state = 0x9E3779B97F4A7C15ull;
  auto next = [&state] {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return state;
  };
  std::size_t accepted = 0, rejected = 0;
  for (const auto& m : test::sample_messages()) {
    const auto bytes = frame_of(m);
    for (int round = 0; round < 400; ++round) {
      auto b = bytes;
      const int edits = 1 + static_cast<int>(next() % 4);
      for (int e = 0; e < edits && !b.empty(); ++e) {
        const std::size_t at = next() % b.size();
        switch (next() % 4) {
          case 0: b[at] ^= static_cast<std::uint8_t>(1u << (next() % 8)); break;
          case 1: b[at] = static_cast<std::uint8_t>(next()); break;
          case 2: b.insert(b.begin() + static_cast<std::ptrdiff_t>(at), static_cast<std::uint8_t>(next())); break;
          default: b.resize(at); break;
        }
      }
      // Keep the header's length consistent half the time so body decoders are reached.
      if (b.size() >= wire::kHeaderBytes && (round & 1))
        put_u32(b, 4, static_cast<std::uint32_t>(b.size() - wire::kHeaderBytes));
      auto d = wire::decode(b);
      if (!d.ok()) {
        EXPECT_FALSE(d.message().empty());
        ++rejected;
        continue;
      }
      ++accepted;
      auto again = wire::encode(d.value());
      ASSERT_TRUE(again.ok()) << again.message();
      auto back = wire::decode(again.value());
      ASSERT_TRUE(back.ok()) << back.message();
      EXPECT_TRUE(back.value() == d.value());
    }
  }
  EXPECT_GT(rejected, 0u);
  EXPECT_GT(accepted, 0u);  // some flips land in free-valued fields and stay valid
}

TEST(Wire, DirectionsAndChannels) {
  EXPECT_EQ(msg::direction_of(msg::MessageType::Hello), msg::Direction::ClientToHost);
  EXPECT_EQ(msg::direction_of(msg::MessageType::EditBatch), msg::Direction::HostToClient);
  EXPECT_EQ(msg::channel_of(msg::MessageType::EditBatch), msg::kChannelModel);
  EXPECT_EQ(msg::channel_of(msg::MessageType::SurfacePatch), msg::kChannelModel);
  EXPECT_EQ(msg::channel_of(msg::MessageType::HeadPose), msg::kChannelControl);
  EXPECT_EQ(msg::channel_of(msg::MessageType::Ack), msg::kChannelControl);
}

}  // namespace
}  // namespace gauss
