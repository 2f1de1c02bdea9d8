#include "io/file_bytes.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <system_error>

#include "gauss/engine/system_memory.h"
#include "io/memory_room.h"

namespace gauss::io {
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

Error file_error(const std::filesystem::path& path, const std::string& what) {
  return Error{path.string() + ": " + what};
}

}  // namespace

Expected<std::vector<std::uint8_t>> read_file_bytes(const std::filesystem::path& path,
                                                    std::atomic<std::uint64_t>* bytes_read) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) return file_error(path, "file not found");
  if (!std::filesystem::is_regular_file(status)) return file_error(path, "not a regular file");
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return file_error(path, "cannot get file size: " + ec.message());
  FilePtr f(std::fopen(path.c_str(), "rb"));
  if (!f) return file_error(path, std::string("cannot open: ") + std::strerror(errno));
  if (auto s = check_memory_room(static_cast<std::size_t>(size), path.string(), "its bytes"); !s) return s.error();
  std::vector<std::uint8_t> bytes;
  try {
    bytes.reserve(static_cast<std::size_t>(size));
    advise_huge_pages_for_room(bytes);  // see resize_cloud
    bytes.resize(static_cast<std::size_t>(size));
  } catch (const std::bad_alloc&) {
    return file_error(path, "not enough memory: its " + std::to_string(size) + " bytes could not be allocated");
  }
  std::size_t got = 0;
  while (got < bytes.size()) {
    const std::size_t want = bytes_read != nullptr ? std::min(kReadChunkBytes, bytes.size() - got) : bytes.size() - got;
    const std::size_t n = std::fread(bytes.data() + got, 1, want, f.get());
    got += n;
    if (bytes_read != nullptr) bytes_read->store(got, std::memory_order_relaxed);
    if (n != want) break;
  }
  if (got != bytes.size())
    return file_error(path, "read " + std::to_string(got) + " of " + std::to_string(bytes.size()) +
                                " bytes (file changed or read error)");
  return bytes;
}

Status write_file_atomic(const std::filesystem::path& path, std::span<const std::uint8_t> bytes) {
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  {
    FilePtr f(std::fopen(tmp.c_str(), "wb"));
    if (!f) return file_error(path, std::string("cannot create temporary file: ") + std::strerror(errno));
    const std::size_t put = bytes.empty() ? 0 : std::fwrite(bytes.data(), 1, bytes.size(), f.get());
    const bool flushed = std::fflush(f.get()) == 0;
    if (put != bytes.size() || !flushed) {
      const std::string why = std::strerror(errno);
      f.reset();
      std::error_code ignored;
      std::filesystem::remove(tmp, ignored);
      return file_error(path, "write failed after " + std::to_string(put) + " of " +
                                  std::to_string(bytes.size()) + " bytes: " + why);
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    return file_error(path, "cannot move the written file into place: " + ec.message());
  }
  return Ok{};
}

}  // namespace gauss::io
