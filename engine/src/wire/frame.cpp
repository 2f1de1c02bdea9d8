// Framing: the 8-byte header and the dispatch from a frame to its body codec.
#include <string>
#include <type_traits>

#include "codecs.h"
#include "gauss/engine/wire.h"

namespace gauss::msg {

const char* to_string(MessageType t) {
  switch (t) {
    case MessageType::Hello: return "Hello";
    case MessageType::Welcome: return "Welcome";
    case MessageType::Refuse: return "Refuse";
    case MessageType::SceneInfo: return "SceneInfo";
    case MessageType::EditBatch: return "EditBatch";
    case MessageType::SurfacePatch: return "SurfacePatch";
    case MessageType::ObjectTableUpdate: return "ObjectTableUpdate";
    case MessageType::HeadPose: return "HeadPose";
    case MessageType::Query: return "Query";
    case MessageType::QueryReply: return "QueryReply";
    case MessageType::Ack: return "Ack";
    case MessageType::ClientStats: return "ClientStats";
    case MessageType::Challenge: return "Challenge";
    case MessageType::AuthProof: return "AuthProof";
    case MessageType::AuthConfirm: return "AuthConfirm";
  }
  return "Unknown";
}

}  // namespace gauss::msg

namespace gauss::wire {
namespace {

template <class T>
constexpr msg::MessageType type_for() {
  if constexpr (std::is_same_v<T, msg::Hello>) return msg::MessageType::Hello;
  else if constexpr (std::is_same_v<T, msg::Welcome>) return msg::MessageType::Welcome;
  else if constexpr (std::is_same_v<T, msg::Refuse>) return msg::MessageType::Refuse;
  else if constexpr (std::is_same_v<T, msg::SceneInfo>) return msg::MessageType::SceneInfo;
  else if constexpr (std::is_same_v<T, msg::EditBatchMsg>) return msg::MessageType::EditBatch;
  else if constexpr (std::is_same_v<T, msg::SurfacePatch>) return msg::MessageType::SurfacePatch;
  else if constexpr (std::is_same_v<T, msg::ObjectTableUpdate>) return msg::MessageType::ObjectTableUpdate;
  else if constexpr (std::is_same_v<T, msg::HeadPose>) return msg::MessageType::HeadPose;
  else if constexpr (std::is_same_v<T, msg::Query>) return msg::MessageType::Query;
  else if constexpr (std::is_same_v<T, msg::QueryReply>) return msg::MessageType::QueryReply;
  else if constexpr (std::is_same_v<T, msg::Ack>) return msg::MessageType::Ack;
  else if constexpr (std::is_same_v<T, msg::Challenge>) return msg::MessageType::Challenge;
  else if constexpr (std::is_same_v<T, msg::AuthProof>) return msg::MessageType::AuthProof;
  else if constexpr (std::is_same_v<T, msg::AuthConfirm>) return msg::MessageType::AuthConfirm;
  else {
    static_assert(std::is_same_v<T, msg::ClientStats>);
    return msg::MessageType::ClientStats;
  }
}

template <class T>
Expected<Message> wrap(Expected<T> e) {
  if (!e) return e.error();
  return Message{std::move(e).value()};
}

}  // namespace

msg::MessageType type_of(const Message& m) {
  return std::visit([](const auto& x) { return type_for<std::decay_t<decltype(x)>>(); }, m);
}

Status encode_append(const Message& m, std::vector<std::uint8_t>& out) {
  const std::size_t start = out.size();
  Status s = std::visit(
      [&](const auto& x) -> Status {
        if (auto c = detail::check(x); !c) return c;
        detail::Writer w(out);
        w.u16(static_cast<std::uint16_t>(type_of(m)));
        w.u16(0);
        w.u32(0);  // body length, patched below
        using T = std::decay_t<decltype(x)>;
        if constexpr (std::is_same_v<T, msg::SurfacePatch>) {
          if (auto ws = detail::write(x, w); !ws) return ws;
        } else {
          detail::write(x, w);
        }
        return Ok{};
      },
      m);
  const std::size_t frame = out.size() - start;
  if (s && frame > msg::kMaxMessageBytes)
    s = Error{std::string(msg::to_string(type_of(m))) + ": encoded size " + std::to_string(frame) +
              " bytes exceeds the message limit " + std::to_string(msg::kMaxMessageBytes)};
  if (!s) {
    out.resize(start);  // leave the caller's buffer as it was
    return s;
  }
  const auto body = static_cast<std::uint32_t>(frame - kHeaderBytes);
  for (int i = 0; i < 4; ++i) out[start + 4 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(body >> (8 * i));
  return Ok{};
}

Expected<std::vector<std::uint8_t>> encode(const Message& m) {
  std::vector<std::uint8_t> out;
  if (auto s = encode_append(m, out); !s) return s.error();
  return out;
}

Expected<FrameHeader> decode_header(std::span<const std::uint8_t> frame) {
  detail::Reader r(frame, "frame");
  std::uint16_t type = 0, reserved = 0;
  std::uint32_t length = 0;
  r.u16("type", type);
  r.u16("reserved", reserved);
  r.u32("body_length", length);
  if (!r.ok()) return r.error();
  const auto bad = [&](const char* field, std::size_t at, const std::string& what) {
    r.fail_at(field, at, what);
    return r.error();
  };
  if (type < msg::kFirstMessageType || type > msg::kLastMessageType)
    return bad("type", 0, "unknown message type " + std::to_string(type));
  if (reserved != 0) return bad("reserved", 2, "must be 0, is " + std::to_string(reserved));
  if (length > msg::kMaxMessageBytes - kHeaderBytes)
    return bad("body_length", 4, std::to_string(length) + " exceeds the message limit");
  if (length != frame.size() - kHeaderBytes)
    return bad("body_length", 4,
               "says " + std::to_string(length) + " bytes, frame carries " + std::to_string(frame.size() - kHeaderBytes));
  return FrameHeader{static_cast<msg::MessageType>(type), length};
}

Expected<Message> decode(std::span<const std::uint8_t> frame) {
  auto h = decode_header(frame);
  if (!h) return h.error();
  const auto body = frame.subspan(kHeaderBytes);
  switch (h->type) {
    case msg::MessageType::Hello: return wrap(decode_hello(body));
    case msg::MessageType::Welcome: return wrap(decode_welcome(body));
    case msg::MessageType::Refuse: return wrap(decode_refuse(body));
    case msg::MessageType::SceneInfo: return wrap(decode_scene_info(body));
    case msg::MessageType::EditBatch: return wrap(decode_edit_batch_msg(body));
    case msg::MessageType::SurfacePatch: return wrap(decode_surface_patch(body));
    case msg::MessageType::ObjectTableUpdate: return wrap(decode_object_table_update(body));
    case msg::MessageType::HeadPose: return wrap(decode_head_pose(body));
    case msg::MessageType::Query: return wrap(decode_query(body));
    case msg::MessageType::QueryReply: return wrap(decode_query_reply(body));
    case msg::MessageType::Ack: return wrap(decode_ack(body));
    case msg::MessageType::ClientStats: return wrap(decode_client_stats(body));
    case msg::MessageType::Challenge: return wrap(decode_challenge(body));
    case msg::MessageType::AuthProof: return wrap(decode_auth_proof(body));
    case msg::MessageType::AuthConfirm: return wrap(decode_auth_confirm(body));
  }
  return Error{"frame: unknown message type"};
}

}  // namespace gauss::wire
