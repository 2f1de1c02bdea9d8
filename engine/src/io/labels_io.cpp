#include "gauss/engine/labels_io.h"

#include <algorithm>
#include <charconv>
#include <string>

#include "io/file_bytes.h"

namespace gauss {

Expected<std::vector<std::int32_t>> parse_labels(std::string_view text, std::string_view name) {
  std::vector<std::int32_t> labels;
  labels.reserve(static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n')) + 1);
  std::size_t pos = 0;
  std::size_t line_no = 0;
  while (pos < text.size()) {
    const std::size_t nl = text.find('\n', pos);
    const std::size_t end = nl == std::string_view::npos ? text.size() : nl;
    ++line_no;
    std::string_view line = text.substr(pos, end - pos);
    pos = nl == std::string_view::npos ? text.size() : nl + 1;
    auto fail = [&](const std::string& what) {
      return Error{std::string(name) + ": line " + std::to_string(line_no) + ": " + what};
    };
    if (line.size() > kMaxLabelLineBytes)
      return fail("longer than " + std::to_string(kMaxLabelLineBytes) + " bytes (not a label file?)");
    const std::size_t first = line.find_first_not_of(" \t\r");
    if (first == std::string_view::npos) return fail("empty line; expected one integer label per line");
    const std::size_t last = line.find_last_not_of(" \t\r");
    const std::string_view token = line.substr(first, last - first + 1);
    std::int32_t v = 0;
    const auto r = std::from_chars(token.data(), token.data() + token.size(), v);
    if (r.ec == std::errc::result_out_of_range) return fail("label '" + std::string(token) + "' is outside the int32 range");
    if (r.ec != std::errc{} || r.ptr != token.data() + token.size())
      return fail("'" + std::string(token) + "' is not an integer label");
    labels.push_back(v);
  }
  return labels;
}

Expected<std::vector<std::int32_t>> read_labels(const std::filesystem::path& path) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes) return bytes.error();
  return parse_labels(std::string_view(reinterpret_cast<const char*>(bytes->data()), bytes->size()), path.string());
}

Status check_label_count(std::span<const std::int32_t> labels, std::size_t gaussian_count, std::string_view labels_name,
                         std::string_view scene_name) {
  if (labels.size() == gaussian_count) return Ok{};
  return Error{std::string(labels_name) + " has " + std::to_string(labels.size()) + " labels but " +
               std::string(scene_name) + " has " + std::to_string(gaussian_count) + " Gaussians"};
}

}  // namespace gauss
