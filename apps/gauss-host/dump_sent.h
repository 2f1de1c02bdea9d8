#pragma once
// gauss-host --dump-sent: what the host sent a client, written when its session ends, so
// a test can render "the host's own render of the set it sent" and compare it byte for
// byte with the client's image.
//   DIR/<name>.ply       the session's sent set (HostSession::sent_ids()), each Gaussian as
//                        it was sent and the client decodes it (HostSession::sent_record,
//                        which sent_checksum() hashes), as a standard 3DGS PLY with
//                        gaussian_id, object_id and support; SH degree = the codec's.
//                        Reading it back gives records whose record_hash() sum equals the
//                        client's published_checksum() once it has converged.
//   DIR/<name>.mesh.ply  the scene's surface at that time, all chunks in chunk-id order
//                        concatenated; only when the scene has a surface.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "gauss/engine/codec.h"
#include "gauss/engine/host_session.h"
#include "gauss/engine/result.h"
#include "gauss/engine/scene_store.h"

namespace gauss::host_app {

// A file name stem for a client: letters, digits, '-' and '_' kept, every other byte
// replaced by '_'; "client-<id>" when the name is empty.
std::string dump_file_stem(std::string_view client_name, std::uint32_t client);

struct DumpReport {
  std::filesystem::path gaussians_path;
  std::size_t gaussians{0};
  std::filesystem::path mesh_path;  // empty: the scene has no surface
  std::size_t triangles{0};
};

// Writes the two files for `session` into `dir` (created when missing). Fails naming the
// file that could not be written; a failed mesh write leaves the Gaussian file written.
Expected<DumpReport> dump_sent(const std::filesystem::path& dir, const std::string& stem, const HostSession& session,
                               const SceneStore& scene, const CodecParams& params);

}  // namespace gauss::host_app
