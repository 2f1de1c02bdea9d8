// The saved fuzz corpora of the wire decoders (tests/fuzz/corpus/wire_<name>/):
// checks that every decoder has one and that it still holds valid encodings of the
// current schema (a schema change without a corpus refresh fails here).
// Regenerate after a deliberate schema change:
//   GAUSS_WRITE_CORPUS=1 build/tests/net_wire_corpus
// Seeds: every sample message's valid encoding, truncations of it, one flipped byte;
// for the frame target also damaged headers.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>

#include <gtest/gtest.h>

#include "gauss/engine/wire.h"
#include "test_data.h"
#include "wire_samples.h"

namespace gauss {
namespace {

namespace fs = std::filesystem;
using Bytes = std::vector<std::uint8_t>;

const std::map<msg::MessageType, std::string>& target_names() {
  static const std::map<msg::MessageType, std::string> names = {
      {msg::MessageType::Hello, "hello"},
      {msg::MessageType::Welcome, "welcome"},
      {msg::MessageType::Refuse, "refuse"},
      {msg::MessageType::SceneInfo, "scene_info"},
      {msg::MessageType::EditBatch, "edit_batch"},
      {msg::MessageType::SurfacePatch, "surface_patch"},
      {msg::MessageType::ObjectTableUpdate, "object_table_update"},
      {msg::MessageType::HeadPose, "head_pose"},
      {msg::MessageType::Query, "query"},
      {msg::MessageType::QueryReply, "query_reply"},
      {msg::MessageType::Ack, "ack"},
      {msg::MessageType::ClientStats, "client_stats"},
      {msg::MessageType::Challenge, "challenge"},
      {msg::MessageType::AuthProof, "auth_proof"},
      {msg::MessageType::AuthConfirm, "auth_confirm"},
  };
  return names;
}

fs::path corpus_root() { return fs::path(GAUSS_SOURCE_DIR) / "tests" / "fuzz" / "corpus"; }

// name -> (file name -> bytes)
std::map<std::string, std::map<std::string, Bytes>> build_seeds() {
  std::map<std::string, std::map<std::string, Bytes>> seeds;
  int index = 0;
  for (const auto& m : test::sample_messages()) {
    auto frame = wire::encode(m);
    if (!frame.ok()) continue;
    const Bytes& f = frame.value();
    const Bytes body(f.begin() + wire::kHeaderBytes, f.end());
    const std::string target = "wire_" + target_names().at(wire::type_of(m));
    const std::string tag = std::to_string(index++);
    auto& t = seeds[target];
    auto& fr = seeds["wire_frame"];
    t["valid_" + tag] = body;
    fr["valid_" + tag] = f;
    for (std::size_t cut : {std::size_t{0}, body.size() / 2, body.size() > 0 ? body.size() - 1 : 0}) {
      t["trunc_" + tag + "_" + std::to_string(cut)] = Bytes(body.begin(), body.begin() + static_cast<std::ptrdiff_t>(cut));
    }
    if (!body.empty()) {
      Bytes flipped = body;
      flipped[flipped.size() / 3] ^= 0x5A;
      t["flip_" + tag] = flipped;
    }
    fr["trunc_" + tag] = Bytes(f.begin(), f.end() - 1);
    Bytes bad_type = f;
    bad_type[0] = 0x7F;
    fr["badtype_" + tag] = bad_type;
    Bytes bad_len = f;
    bad_len[5] ^= 0x10;
    fr["badlen_" + tag] = bad_len;
  }
  return seeds;
}

TEST(WireCorpus, EveryDecoderHasACurrentCorpus) {
  const auto seeds = build_seeds();
  ASSERT_EQ(seeds.size(), target_names().size() + 1) << "a decoder has no seeds";
  if (const char* w = std::getenv("GAUSS_WRITE_CORPUS"); w && std::string(w) == "1") {
    for (const auto& [target, files] : seeds) {
      const fs::path dir = corpus_root() / target;
      fs::create_directories(dir);
      for (const auto& [name, bytes] : files) {
        std::ofstream out(dir / name, std::ios::binary);
        out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
        ASSERT_TRUE(out.good()) << "cannot write " << (dir / name);
      }
    }
  }
  for (const auto& [target, files] : seeds) {
    const fs::path dir = corpus_root() / target;
    ASSERT_TRUE(fs::is_directory(dir)) << dir << " missing: run GAUSS_WRITE_CORPUS=1 net_wire_corpus";
    std::size_t valid = 0;
    for (const auto& e : fs::directory_iterator(dir)) {
      if (e.path().filename().string().rfind("valid_", 0) != 0) continue;
      std::ifstream in(e.path(), std::ios::binary);
      Bytes bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      if (target == "wire_frame") {
        auto d = wire::decode(bytes);
        EXPECT_TRUE(d.ok()) << e.path() << ": " << (d.ok() ? "" : d.message());
      } else {
        Bytes frame(wire::kHeaderBytes, 0);
        // Re-frame the body with its target's type to decode it through the dispatcher.
        for (const auto& [type, name] : target_names())
          if ("wire_" + name == target) {
            const auto t = static_cast<std::uint16_t>(type);
            frame[0] = static_cast<std::uint8_t>(t);
            frame[1] = static_cast<std::uint8_t>(t >> 8);
          }
        const auto len = static_cast<std::uint32_t>(bytes.size());
        for (int i = 0; i < 4; ++i) frame[4 + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(len >> (8 * i));
        frame.insert(frame.end(), bytes.begin(), bytes.end());
        auto d = wire::decode(frame);
        EXPECT_TRUE(d.ok()) << e.path() << ": " << (d.ok() ? "" : d.message());
      }
      ++valid;
    }
    EXPECT_GT(valid, 0u) << dir << " holds no valid seed";
  }
}

}  // namespace
}  // namespace gauss
