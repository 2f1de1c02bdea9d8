// Zip reading through libzip (zip_archive.h).
#include "io/zip_archive.h"

#include <zip.h>

namespace gauss::io {
namespace {

std::string libzip_text(zip_error_t* e) {
  const char* s = zip_error_strerror(e);
  return s ? std::string(s) : std::string("unknown libzip error");
}

}  // namespace

void ZipArchive::Closer::operator()(zip* z) const {
  if (z) zip_discard(z);  // read-only: nothing to write back
}

Expected<ZipArchive> ZipArchive::open(std::span<const std::uint8_t> bytes, std::string_view name) {
  zip_error_t error;
  zip_error_init(&error);
  // An empty span may have a null data pointer; libzip accepts (nullptr, 0).
  zip_source_t* source = zip_source_buffer_create(bytes.empty() ? nullptr : bytes.data(), bytes.size(), 0, &error);
  if (!source) {
    std::string what = libzip_text(&error);
    zip_error_fini(&error);
    return Error{std::string(name) + ": cannot read as a zip archive (" + what + ")"};
  }
  zip_t* z = zip_open_from_source(source, ZIP_RDONLY, &error);
  if (!z) {
    zip_source_free(source);  // still ours when the open failed
    std::string what = libzip_text(&error);
    zip_error_fini(&error);
    return Error{std::string(name) + ": not a readable zip archive (" + what + "; " + std::to_string(bytes.size()) +
                 " bytes: truncated or damaged?)"};
  }
  zip_error_fini(&error);
  return ZipArchive(z, std::string(name));
}

std::vector<std::string> ZipArchive::entry_names() const {
  std::vector<std::string> names;
  const zip_int64_t n = zip_get_num_entries(zip_.get(), 0);
  for (zip_int64_t i = 0; i < n; ++i)
    if (const char* s = zip_get_name(zip_.get(), static_cast<zip_uint64_t>(i), 0)) names.emplace_back(s);
  return names;
}

bool ZipArchive::contains(std::string_view entry) const {
  return zip_name_locate(zip_.get(), std::string(entry).c_str(), 0) >= 0;
}

Expected<std::vector<std::uint8_t>> ZipArchive::read(std::string_view entry, std::size_t max_bytes) const {
  const std::string who = name_ + ": entry '" + std::string(entry) + "'";
  const zip_int64_t index = zip_name_locate(zip_.get(), std::string(entry).c_str(), 0);
  if (index < 0) return Error{who + " is not in the archive"};
  zip_stat_t st;
  zip_stat_init(&st);
  if (zip_stat_index(zip_.get(), static_cast<zip_uint64_t>(index), 0, &st) != 0 || !(st.valid & ZIP_STAT_SIZE))
    return Error{who + ": no size in the zip directory (" + libzip_text(zip_get_error(zip_.get())) + ")"};
  if (st.size > max_bytes)
    return Error{who + " declares " + std::to_string(st.size) + " bytes, more than the " + std::to_string(max_bytes) +
                 " this reader accepts"};
  zip_file_t* f = zip_fopen_index(zip_.get(), static_cast<zip_uint64_t>(index), 0);
  if (!f) return Error{who + ": cannot open (" + libzip_text(zip_get_error(zip_.get())) + ")"};
  std::vector<std::uint8_t> out(static_cast<std::size_t>(st.size));
  std::size_t got = 0;
  std::string failure;
  while (got < out.size()) {
    const zip_int64_t r = zip_fread(f, out.data() + got, out.size() - got);
    if (r < 0) {
      failure = libzip_text(zip_file_get_error(f));
      break;
    }
    if (r == 0) {
      failure = "data ends after " + std::to_string(got) + " of the " + std::to_string(out.size()) +
                " bytes the directory declares";
      break;
    }
    got += static_cast<std::size_t>(r);
  }
  if (failure.empty()) {
    // One more read reaches the end of the stream, where libzip checks the CRC.
    std::uint8_t extra = 0;
    const zip_int64_t r = zip_fread(f, &extra, 1);
    if (r < 0) failure = libzip_text(zip_file_get_error(f));
    else if (r > 0) failure = "holds more data than the " + std::to_string(out.size()) + " bytes its directory declares";
  }
  zip_fclose(f);
  if (!failure.empty()) return Error{who + ": damaged (" + failure + ")"};
  return out;
}

}  // namespace gauss::io
