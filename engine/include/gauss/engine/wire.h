#pragma once
// Binary encoding of the messages in gauss/engine/messages.h. CPU only and free of
// sockets, so the deterministic simulation moves the very bytes ENet would.
//
// Frame layout (all integers little-endian, floats IEEE-754 binary32 LE):
//   u16 type | u16 reserved (= 0) | u32 body_length | body (body_length bytes)
// The body of each type is a fixed sequence of fields (see engine/src/wire/*.cpp);
// strings and vectors carry a u32 count first. A frame is exactly header + body:
// trailing bytes are an error.
//
// Decoders validate every field against the bounds in messages.h and return an
// Error naming the message, the field and the byte offset; they never throw,
// never assert on input, and never allocate more than the bytes present justify
// (every count is checked against the remaining bytes before reserving).
#include <cstddef>
#include <cstdint>
#include <span>
#include <variant>
#include <vector>

#include "gauss/engine/messages.h"
#include "gauss/engine/result.h"

namespace gauss::wire {

using Message = std::variant<msg::Hello, msg::Welcome, msg::Refuse, msg::SceneInfo, msg::EditBatchMsg,
                             msg::SurfacePatch, msg::ObjectTableUpdate, msg::HeadPose, msg::Query,
                             msg::QueryReply, msg::Ack, msg::ClientStats, msg::Challenge, msg::AuthProof,
                             msg::AuthConfirm>;

inline constexpr std::size_t kHeaderBytes = 8;

struct FrameHeader {
  msg::MessageType type{msg::MessageType::Hello};
  std::uint32_t body_length{0};
};

msg::MessageType type_of(const Message& m);

// Encodes one framed message. Fails only when the message itself breaks the
// schema's bounds (an encoder never writes what the decoder would refuse), e.g. an
// oversized token or a NaN position; the error names the field.
Expected<std::vector<std::uint8_t>> encode(const Message& m);
// Appends the frame to `out`; on failure `out` is left exactly as it was.
Status encode_append(const Message& m, std::vector<std::uint8_t>& out);

// Reads and checks the 8-byte header: known type, reserved zero, body length
// within kMaxMessageBytes and equal to the bytes that follow.
Expected<FrameHeader> decode_header(std::span<const std::uint8_t> frame);
// Decodes one whole frame.
Expected<Message> decode(std::span<const std::uint8_t> frame);

// Body decoders, one per type (the frame decoder dispatches to these; the fuzz
// targets call them directly). `body` excludes the header.
Expected<msg::Hello> decode_hello(std::span<const std::uint8_t> body);
Expected<msg::Welcome> decode_welcome(std::span<const std::uint8_t> body);
Expected<msg::Refuse> decode_refuse(std::span<const std::uint8_t> body);
Expected<msg::Challenge> decode_challenge(std::span<const std::uint8_t> body);
Expected<msg::AuthProof> decode_auth_proof(std::span<const std::uint8_t> body);
Expected<msg::AuthConfirm> decode_auth_confirm(std::span<const std::uint8_t> body);
Expected<msg::SceneInfo> decode_scene_info(std::span<const std::uint8_t> body);
Expected<msg::EditBatchMsg> decode_edit_batch_msg(std::span<const std::uint8_t> body);
Expected<msg::SurfacePatch> decode_surface_patch(std::span<const std::uint8_t> body);
Expected<msg::ObjectTableUpdate> decode_object_table_update(std::span<const std::uint8_t> body);
Expected<msg::HeadPose> decode_head_pose(std::span<const std::uint8_t> body);
Expected<msg::Query> decode_query(std::span<const std::uint8_t> body);
Expected<msg::QueryReply> decode_query_reply(std::span<const std::uint8_t> body);
Expected<msg::Ack> decode_ack(std::span<const std::uint8_t> body);
Expected<msg::ClientStats> decode_client_stats(std::span<const std::uint8_t> body);

}  // namespace gauss::wire
