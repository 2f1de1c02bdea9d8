#pragma once
// THE wire schema: every message host and client exchange, as plain structs.
// This header is the one place a message is defined; the binary encoders and
// decoders (gauss/engine/wire.h, engine/src/wire/) and the tests follow it.
//
// Rules of the schema
// - A message type number never changes meaning. A changed message becomes a new
//   type (e.g. HeadPose2 = 13) and the old one stays decodable or is refused by
//   protocol version; fields are never silently added to an existing type.
// - Hello, Welcome and Refuse are frozen forever: they carry the protocol version,
//   so a peer of any version can read them and refuse cleanly.
// - Ids travel on the wire (GaussianId, ObjectId, Epoch), never client slots.
// - Every bound below is enforced by the decoder; a message outside it is rejected
//   with a reason, never truncated or clamped silently.
//
// Directions: H->C messages are sent by the host only, C->H by the client only;
// a receiver rejects (and counts) a message of the wrong direction.
// Channels: the model stream (edits, surface, objects, scene info, handshake
// replies) is one reliable ordered channel; pose, queries, acks and stats share
// the second channel (see channel_of()).
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include "gauss/engine/codec.h"
#include "gauss/engine/ids.h"
#include "gauss/engine/mesh.h"
#include "gauss/engine/slot_table.h"

namespace gauss::msg {

// Bumped whenever a message type is added or retired. A host refuses a Hello with a
// different version (RefuseReason::VersionMismatch) instead of guessing.
// 2: Challenge / AuthProof. 3: the handshake is CPace (a PAKE): Challenge and AuthProof
// carry CPace messages, AuthConfirm is new. 4: SceneInfo carries the scene's view (up,
// the subject's box, where the capture stood).
inline constexpr std::uint32_t kProtocolVersion = 4;

// ---- Bounds (each enforced by the decoder) ----------------------------------
// Largest encoded message, header included. The host sends one edit batch per
// epoch per client, and a resync snapshot holds the whole desired set: 400k SH3
// records are ~26 MiB before zstd, so 64 MiB leaves room without letting a peer
// claim an unbounded packet (the transport sets ENet's packet limit to this).
inline constexpr std::size_t kMaxMessageBytes = 64u << 20;
// Slot capacity a client may ask for: gauss::kMaxSlotCapacity (slot_table.h), the
// same bound SlotTable::create enforces, so a Hello the host accepts always fits.
inline constexpr std::size_t kMaxTokenBytes = 256;      // access token (opaque bytes)
inline constexpr std::size_t kMaxLabelBytes = 256;      // object class label, UTF-8
inline constexpr std::size_t kMaxQueryTextBytes = 256;  // query class text, UTF-8
inline constexpr std::size_t kMaxReasonBytes = 1024;    // human-readable refusal text
inline constexpr std::size_t kMaxObjects = 1u << 16;    // objects per table / update
inline constexpr std::size_t kMaxQueryTargets = 1u << 16;
// Decompressed surface chunk: vertices and indices per patch. A TSDF chunk of
// 16^3 voxels yields at most a few tens of thousands of triangles.
inline constexpr std::size_t kMaxChunkVertices = 1u << 20;
inline constexpr std::size_t kMaxChunkIndices = 3u << 20;
inline constexpr std::uint32_t kMaxEditsPerBatch = 1u << 22;

// ---- Transport channels -------------------------------------------------------
inline constexpr std::uint8_t kChannelModel = 0;    // reliable, ordered
inline constexpr std::uint8_t kChannelControl = 1;  // pose/query/ack/stats
inline constexpr std::uint8_t kChannelCount = 2;

enum class MessageType : std::uint16_t {
  Hello = 1,              // C->H  handshake (frozen)
  Welcome = 2,            // H->C  handshake accepted (frozen)
  Refuse = 3,             // H->C  handshake refused; the host disconnects after it (frozen)
  SceneInfo = 4,          // H->C  bounds, SH degree, full object table
  EditBatch = 5,          // H->C  epoch + codec bytes (quantised records, zstd)
  SurfacePatch = 6,       // H->C  one TSDF mesh chunk of an epoch
  ObjectTableUpdate = 7,  // H->C  objects added/changed/removed at an epoch
  HeadPose = 8,           // C->H  coarse head pose (~10 Hz)
  Query = 9,              // C->H  semantic query or clear
  QueryReply = 10,        // H->C  how the host resolved a query
  Ack = 11,               // C->H  epochs received / published
  ClientStats = 12,       // C->H  client counters for the host's log
  Challenge = 13,         // H->C  handshake: prove you hold the access token (CPace, from version 3)
  AuthProof = 14,         // C->H  handshake: the proof (CPace, from version 3)
  AuthConfirm = 15,       // H->C  handshake: the host proves it holds the token too
};
inline constexpr std::uint16_t kFirstMessageType = 1;
inline constexpr std::uint16_t kLastMessageType = 15;

enum class Direction : std::uint8_t { ClientToHost, HostToClient };

constexpr Direction direction_of(MessageType t) {
  switch (t) {
    case MessageType::Hello:
    case MessageType::HeadPose:
    case MessageType::Query:
    case MessageType::Ack:
    case MessageType::ClientStats:
    case MessageType::AuthProof:
      return Direction::ClientToHost;
    default:
      return Direction::HostToClient;
  }
}

// The model stream (and the handshake replies that must precede it) rides the
// reliable ordered channel; the rest is small, frequent control traffic.
constexpr std::uint8_t channel_of(MessageType t) {
  switch (t) {
    case MessageType::HeadPose:
    case MessageType::Query:
    case MessageType::QueryReply:
    case MessageType::Ack:
    case MessageType::ClientStats:
      return kChannelControl;
    default:
      return kChannelModel;
  }
}

const char* to_string(MessageType t);

// ---- Handshake ------------------------------------------------------------------

// First message of every connection, also of every reconnect.
struct Hello {
  std::uint32_t protocol_version{kProtocolVersion};
  std::uint32_t slot_capacity{0};  // M: most Gaussians the client can hold, in [1, gauss::kMaxSlotCapacity]
  std::string access_token;        // empty when none; at most kMaxTokenBytes
  std::string client_name;         // for logs only; at most kMaxLabelBytes
  bool operator==(const Hello&) const = default;
};

// The host accepted the client. Every Welcome starts a fresh host-side view of the
// client: the host assumes the client's desired set is EMPTY and resends what it
// wants resident. A reconnecting client therefore treats its current desired set
// as pending removal, cancelled id by id by the re-sent inserts (equal records cost
// nothing to publish), and resends its current query and pose.
struct Welcome {
  std::uint32_t protocol_version{kProtocolVersion};
  std::uint64_t session_id{0};    // host process session (a new value = host restarted)
  std::uint32_t client_id{0};     // host-assigned, unique within the session
  std::uint32_t slot_capacity{0}; // granted M (<= requested)
  bool operator==(const Welcome&) const = default;
};

enum class RefuseReason : std::uint8_t {
  VersionMismatch = 1,
  BadToken = 2,
  BadCapacity = 3,
  HostFull = 4,
  Malformed = 5,      // the first message was not a valid Hello
  Other = 6,
};
inline constexpr std::uint8_t kLastRefuseReason = 6;

// Whether a refusal is about the host's state now rather than about the Hello: HostFull
// covers the host's client limit, this address's share of it, and the rates of new
// sessions and of authentication proofs. The same Hello may be welcomed later, so a client
// that reconnects tries again (backing off); every other reason stands until the client
// changes its token, version or capacity.
constexpr bool refusal_is_transient(RefuseReason r) { return r == RefuseReason::HostFull; }

struct Refuse {
  RefuseReason reason{RefuseReason::Other};
  std::uint32_t host_protocol_version{kProtocolVersion};
  std::string detail;  // at most kMaxReasonBytes
  bool operator==(const Refuse&) const = default;
};

// Token authentication over a network: CPace, a password-authenticated key exchange
// (gauss/net/auth.h, gauss/net/cpace.h). The secret never crosses the wire, and nothing
// that does lets anyone test a guess of it offline: a guess costs a live exchange with
// the host (or, posing as a host, with a client), one guess per connection.
//   client: Hello (empty access_token)
//   host:   Challenge  nonce (the CPace sid), flags, one CPace message per secret the
//                      host accepts (the access token; a pairing code)
//   client: AuthProof  which secret it answers for, its CPace message, its key
//                      confirmation tag
//   host:   AuthConfirm the host's tag (only after the client's tag verified), then
//                      Welcome or Refuse as without a token
// Both sides derive the tags and the sealed stream's keys from CPace's ISK, the Hello's
// bytes and the Challenge's bytes: the flags (kChallengeEncrypt) cannot be altered on the
// path, and the keys come from both sides' fresh scalars (forward secrecy).
// Challenge and AuthProof changed in place at version 3 (the Hello's version check comes
// before either, so no peer of another version ever decodes them). Hello.access_token
// stays for in-process links, where there is no wire.
inline constexpr std::size_t kAuthNonceBytes = 32;
// A CPace message as the draft encodes it, prefix_free_cat(Y, AD), with Y one 32-byte
// ristretto255 element and AD empty: 0x20 || Y || 0x00.
inline constexpr std::size_t kPakePointBytes = 32;
inline constexpr std::size_t kPakeMessageBytes = 1 + kPakePointBytes + 1;
inline constexpr std::size_t kAuthTagBytes = 32;

// Challenge flags. kChallengeEncrypt: everything after the handshake, both ways, travels
// sealed under keys from the exchange (gauss/net/stream_cipher.h).
inline constexpr std::uint8_t kChallengeEncrypt = 1;
inline constexpr std::uint8_t kChallengeKnownFlags = kChallengeEncrypt;

// The secrets a host may accept (one CPace message each).
enum class AuthSecret : std::uint8_t {
  AccessToken = 1,  // the token (--token)
  PairingCode = 2,  // the short code a person types (8 Crockford base32 symbols)
};
inline constexpr std::uint8_t kLastAuthSecret = 2;
inline constexpr std::size_t kMaxAuthOffers = kLastAuthSecret;

using PakeMessage = std::array<std::uint8_t, kPakeMessageBytes>;
using AuthTag = std::array<std::uint8_t, kAuthTagBytes>;

struct AuthOffer {
  AuthSecret secret{AuthSecret::AccessToken};
  PakeMessage pake{};  // the host's CPace message (initiator) for this secret
  bool operator==(const AuthOffer&) const = default;
};

struct Challenge {
  std::array<std::uint8_t, kAuthNonceBytes> nonce{};
  std::uint8_t flags{0};  // kChallenge* bits; others must be 0
  std::vector<AuthOffer> offers;  // 1..kMaxAuthOffers, each secret at most once
  bool operator==(const Challenge&) const = default;
};

struct AuthProof {
  AuthSecret secret{AuthSecret::AccessToken};  // the offer answered
  PakeMessage pake{};  // the client's CPace message (responder)
  AuthTag tag{};       // the client's key confirmation
  bool operator==(const AuthProof&) const = default;
};

struct AuthConfirm {
  AuthTag tag{};  // the host's key confirmation
  bool operator==(const AuthConfirm&) const = default;
};

// ---- Model stream (host -> client) -------------------------------------------------

// The wire form of a SemanticObject: its member list stays on the host (members
// reach the client as Gaussians carrying their ObjectId).
struct ObjectInfo {
  ObjectId id{kNoObject};        // >= 0
  std::string label;             // at most kMaxLabelBytes
  glm::vec3 centroid{0.0f};
  glm::vec3 extent_min{0.0f};    // extent_min <= extent_max per axis
  glm::vec3 extent_max{0.0f};
  float quality{0.0f};           // [0, 1]
  std::uint32_t member_count{0};
  bool operator==(const ObjectInfo&) const = default;
};

// How a viewer first looks at the scene, from the host, which knows where it came from (a
// splat file is y down by the 3DGS convention, a trainer's cameras say their own up, the
// synthetic room is y up): without it a client guesses +y and shows a capture upside down,
// and frames the raw bounds, which a real capture's floaters make many times its size.
// A desktop viewer keeps `up` upright and frames `subject_*`; a headset turns the scene so
// that `up` points up in the room.
inline constexpr std::uint8_t kViewInside = 1u << 0;      // stand inside the box (a room), not outside it
inline constexpr std::uint8_t kViewSeenFrom = 1u << 1;    // seen_from holds where the capture stood
inline constexpr std::uint8_t kViewKnownFlags = kViewInside | kViewSeenFrom;
struct SceneView {
  glm::vec3 up{0.0f, 1.0f, 0.0f};  // unit (within 1e-3)
  // The box a first view frames: the opacity-weighted 2nd..98th percentiles of the centres
  // for a capture (faint floaters left out), the room for the synthetic scene. min <= max.
  glm::vec3 subject_min{0.0f};
  glm::vec3 subject_max{0.0f};
  std::uint8_t flags{0};
  glm::vec3 seen_from{0.0f};  // with kViewSeenFrom: the capture cameras' mean position
  bool operator==(const SceneView&) const = default;
};

// Sent after Welcome (before any EditBatch) and whenever the scene's frame
// changes. Replaces the client's whole object table. `codec` holds the
// quantisation ranges every later EditBatch payload is decoded with; its
// sh_degree is the scene's SH degree.
struct SceneInfo {
  Epoch epoch{0};
  glm::vec3 bounds_min{0.0f};
  glm::vec3 bounds_max{0.0f};
  CodecParams codec{};                // must pass validate_codec_params()
  std::uint64_t total_gaussians{0};   // host scene size (informational)
  std::vector<ObjectInfo> objects;    // ids unique; at most kMaxObjects
  SceneView view{};
};
bool operator==(const SceneInfo& a, const SceneInfo& b);

// EditBatch flags.
// A snapshot: the payload is the client's complete desired set at `epoch`, inserts
// only (DesiredState::apply_resync). The host sends one after every Welcome, preceded on
// the same ordered channel by a SurfacePatch for every chunk the scene holds: applying the
// snapshot drops (behind the epoch barrier) any chunk the client holds that was not resent.
inline constexpr std::uint8_t kBatchResync = 1u << 0;
inline constexpr std::uint8_t kBatchKnownFlags = kBatchResync;

// One edit batch: the epoch it came from and the "select" codec's bytes
// (encode_edit_batch output: quantised records, zstd). Batches go out in
// non-decreasing epoch order on the reliable channel; several may carry the same
// epoch (a pose or query change re-selects without a new scene epoch), and the
// client's published epoch never goes backwards. The wire keeps the payload opaque; the client decodes it with
// decode_edit_batch and the SceneInfo's codec params.
struct EditBatchMsg {
  Epoch epoch{0};
  std::uint64_t batch_id{0};       // per client, strictly increasing (stage events, acks)
  std::uint32_t edit_count{0};     // edits in the payload, <= kMaxEditsPerBatch
  std::uint8_t flags{0};           // kBatch* bits only
  std::uint64_t host_time_us{0};   // host monotonic time the epoch became available (stage events)
  std::vector<std::uint8_t> payload;
  bool operator==(const EditBatchMsg&) const = default;
};

// One TSDF surface chunk at an epoch. An empty mesh removes the chunk. The client
// commits it only once every Gaussian edit of epochs <= epoch is published or
// superseded (SurfaceStage). On the wire the mesh is zstd-compressed.
struct SurfacePatch {
  Epoch epoch{0};
  std::uint64_t chunk_id{0};
  TriangleMesh mesh;  // colors.size() == positions.size(); indices % 3 == 0; every index < vertices
};
bool operator==(const SurfacePatch& a, const SurfacePatch& b);

struct ObjectTableUpdate {
  Epoch epoch{0};
  std::vector<ObjectInfo> upserts;   // added or changed; ids unique
  std::vector<ObjectId> removed;     // ids unique, disjoint from upserts
  bool operator==(const ObjectTableUpdate&) const = default;
};

// ---- Control (client -> host and replies) -------------------------------------------

// Coarse head pose, ~10 Hz. Pose of the head in the world, OpenCV convention
// (x right, y down, z forward), i.e. T_world_head. A pose older (by sequence)
// than one already applied is ignored by the host.
struct HeadPose {
  std::uint32_t sequence{0};
  std::uint64_t client_time_us{0};
  glm::vec3 position{0.0f};                     // finite
  glm::vec4 rotation{1.0f, 0.0f, 0.0f, 0.0f};   // w, x, y, z; finite, |q| within 1e-3 of 1
  float tan_half_fov_x{1.0f};                   // tan of half the horizontal FOV, (0, 100]
  float tan_half_fov_y{1.0f};                   // tan of half the vertical FOV, (0, 100]
  bool operator==(const HeadPose&) const = default;
};

enum class QueryKind : std::uint8_t {
  Clear = 0,      // drop the current query: plain budgeted selection
  ClassText = 1,  // `text`: class label, matched case-insensitively
  Instance = 2,   // `instance`: one object id
};
inline constexpr std::uint8_t kLastQueryKind = 2;

// A Query's rho asking for the host's default share (gauss-host --rho).
inline constexpr float kHostDefaultRho = -1.0f;

struct Query {
  std::uint32_t query_id{0};   // client-chosen, increasing; the reply echoes it
  QueryKind kind{QueryKind::Clear};
  std::string text;            // ClassText only (non-empty, <= kMaxQueryTextBytes); empty otherwise
  ObjectId instance{kNoObject};// Instance only (>= 0); kNoObject otherwise
  float rho{0.0f};             // share of the budget reserved for the target, [0, 1]; 0 for Clear;
                               // kHostDefaultRho: the host's default
  bool operator==(const Query&) const = default;
};

enum class QueryStatus : std::uint8_t {
  Resolved = 0,   // targets found; selection now favours them
  NoMatch = 1,    // valid query, nothing matched (selection unchanged)
  Cleared = 2,    // a Clear was applied
  Rejected = 3,   // refused (rate limit, invalid); `reason` says why; selection unchanged
};
inline constexpr std::uint8_t kLastQueryStatus = 3;

struct QueryReply {
  std::uint32_t query_id{0};
  QueryStatus status{QueryStatus::Resolved};
  Epoch epoch{0};                     // host epoch the resolution used
  std::vector<ObjectId> targets;      // resolved instances; at most kMaxQueryTargets
  std::uint64_t target_gaussians{0};  // Gaussians the targets hold on the host
  std::string reason;                 // Rejected/NoMatch detail; at most kMaxReasonBytes
  bool operator==(const QueryReply&) const = default;
};

// What the client holds. received_epoch: newest epoch whose batches all arrived;
// published_epoch: newest epoch fully published to slots.
struct Ack {
  std::uint64_t last_batch_id{0};
  Epoch received_epoch{0};
  Epoch published_epoch{0};           // <= received_epoch
  bool operator==(const Ack&) const = default;
};

struct ClientStats {
  std::uint64_t client_time_us{0};
  std::uint64_t frames{0};
  std::uint32_t resident{0};          // published Gaussians (<= capacity)
  std::uint32_t desired{0};           // Gaussians in the desired set
  std::uint32_t pending_edits{0};
  std::uint32_t capacity{0};
  float frame_ms{0.0f};               // recent display frame time, finite, >= 0
  float slack_ms{0.0f};               // recent display slack, finite
  std::uint32_t rejected_messages{0}; // messages the client refused so far
  bool operator==(const ClientStats&) const = default;
};

}  // namespace gauss::msg
