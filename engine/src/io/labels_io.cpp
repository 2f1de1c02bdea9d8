#include "gauss/engine/labels_io.h"

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <utility>
#include <string>

#include <nlohmann/json.hpp>

#include "io/file_bytes.h"

namespace gauss {

namespace {

// A segments.ai point-cloud segmentation export: dataset.samples[0].labels.<labelset>
// .attributes {annotations: [{id, category_id}], point_annotations: [annotation id per point,
// 0 = none]}. Each point's label is its annotation's category id, so it matches the object
// table objects_json reads from the same file (its categories).
Expected<std::vector<std::int32_t>> parse_segments_ai_labels(std::string_view text, std::string_view name) {
  using nlohmann::json;
  const std::string who(name);
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    return Error{who + ": malformed JSON at byte " + std::to_string(e.byte) + " (a segments.ai export was expected)"};
  }
  auto fail = [&](const std::string& what) { return Error{who + ": segments.ai export: " + what}; };
  const json* samples = nullptr;
  if (doc.is_object() && doc.contains("dataset") && doc["dataset"].is_object() && doc["dataset"].contains("samples"))
    samples = &doc["dataset"]["samples"];
  if (!samples || !samples->is_array() || samples->empty()) return fail("no dataset.samples");
  if (samples->size() != 1) return fail(std::to_string(samples->size()) + " samples; one scene per file is read");
  const json& labels = (*samples)[0].value("labels", json::object());
  if (!labels.is_object() || labels.empty()) return fail("samples[0] has no labels");
  const json& set = labels.begin().value();  // the first label set (ground-truth in exports)
  if (!set.is_object() || !set.contains("attributes") || !set["attributes"].is_object())
    return fail("label set '" + labels.begin().key() + "' has no attributes");
  const json& attr = set["attributes"];
  if (!attr.contains("point_annotations") || !attr["point_annotations"].is_array())
    return fail("no point_annotations array (not a point-cloud segmentation?)");
  std::vector<std::pair<std::int64_t, std::int32_t>> category_of;  // annotation id -> category id
  if (attr.contains("annotations")) {
    if (!attr["annotations"].is_array()) return fail("annotations is not an array");
    for (std::size_t i = 0; i < attr["annotations"].size(); ++i) {
      const json& a = attr["annotations"][i];
      if (!a.is_object() || !a.contains("id") || !a["id"].is_number_integer() || !a.contains("category_id") ||
          !a["category_id"].is_number_integer())
        return fail("annotations[" + std::to_string(i) + "] needs integer id and category_id");
      const auto cat = a["category_id"].get<std::int64_t>();
      if (cat < 0 || cat > INT32_MAX) return fail("annotations[" + std::to_string(i) + "] category_id out of range");
      category_of.emplace_back(a["id"].get<std::int64_t>(), static_cast<std::int32_t>(cat));
    }
  }
  std::sort(category_of.begin(), category_of.end());
  const json& points = attr["point_annotations"];
  std::vector<std::int32_t> out;
  out.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const json& p = points[i];
    // Exports write the ids as numbers, sometimes as floats (1.0): whole numbers only.
    const double v = p.is_number() ? p.get<double>() : -1.0;
    if (!(v >= 0.0) || v != static_cast<double>(static_cast<std::int64_t>(v)) || v > 2147483647.0)
      return fail("point_annotations[" + std::to_string(i) + "] is not a whole annotation id >= 0");
    const auto id = static_cast<std::int64_t>(v);
    if (id == 0) {
      out.push_back(0);
      continue;
    }
    const auto it = std::lower_bound(category_of.begin(), category_of.end(), std::make_pair(id, INT32_MIN));
    if (it == category_of.end() || it->first != id)
      return fail("point_annotations[" + std::to_string(i) + "] names annotation " + std::to_string(id) +
                  ", which annotations does not list");
    out.push_back(it->second);
  }
  return out;
}

}  // namespace

Expected<std::vector<std::int32_t>> parse_labels(std::string_view text, std::string_view name) {
  const std::size_t start = text.find_first_not_of(" \t\r\n");
  if (start != std::string_view::npos && text[start] == '{') return parse_segments_ai_labels(text, name);
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
