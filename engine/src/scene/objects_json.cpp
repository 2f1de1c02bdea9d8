#include "gauss/engine/objects_json.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "io/file_bytes.h"

namespace gauss {
namespace {

using nlohmann::json;

Expected<ObjectId> parse_id(const json& v, const std::string& where) {
  std::int64_t id = -1;
  if (v.is_number_integer()) {
    id = v.get<std::int64_t>();
  } else if (v.is_number_unsigned()) {
    const auto u = v.get<std::uint64_t>();
    id = u > std::uint64_t(std::numeric_limits<std::int32_t>::max()) ? -1 : std::int64_t(u);
    if (id < 0) return Error{where + ": id " + std::to_string(u) + " is not an int32"};
  } else if (v.is_string()) {
    const std::string& s = v.get_ref<const std::string&>();
    auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), id);
    if (ec != std::errc() || end != s.data() + s.size()) return Error{where + ": id \"" + s + "\" is not an integer"};
  } else {
    return Error{where + ": id is not an integer"};
  }
  if (id < 0 || id > std::numeric_limits<std::int32_t>::max())
    return Error{where + ": id " + std::to_string(id) + " is negative or not an int32"};
  return ObjectId{static_cast<std::int32_t>(id)};
}

Status add(std::vector<ObjectLabel>& out, const json& id, const json& label, const json* quality,
           const std::string& where) {
  auto oid = parse_id(id, where);
  if (!oid) return oid.error();
  if (!label.is_string()) return Error{where + ": label is not a string"};
  ObjectLabel o;
  o.id = *oid;
  o.label = label.get<std::string>();
  if (o.label.empty()) return Error{where + ": label is empty"};
  if (quality) {
    if (!quality->is_number()) return Error{where + ": quality is not a number"};
    const double q = quality->get<double>();
    if (!(q >= 0.0 && q <= 1.0)) return Error{where + ": quality " + std::to_string(q) + " is outside [0, 1]"};
    o.quality = float(q);
  }
  out.push_back(std::move(o));
  return Ok{};
}

}  // namespace

Expected<std::vector<ObjectLabel>> parse_objects_json(std::string_view text, std::string_view name) {
  const std::string who(name);
  json doc;
  try {
    doc = json::parse(text.begin(), text.end());
  } catch (const json::parse_error& e) {  // nlohmann reports by exception; converted here, never escapes
    return Error{who + ": malformed JSON at byte " + std::to_string(e.byte) + ": " + e.what()};
  }
  std::vector<ObjectLabel> out;
  if (!doc.is_object()) return Error{who + ": top level is not a JSON object"};
  if (doc.contains("objects")) {
    const json& arr = doc["objects"];
    if (!arr.is_array()) return Error{who + ": \"objects\" is not an array"};
    for (std::size_t i = 0; i < arr.size(); ++i) {
      const std::string where = who + ": objects[" + std::to_string(i) + "]";
      const json& e = arr[i];
      if (!e.is_object() || !e.contains("id") || !e.contains("label"))
        return Error{where + ": needs an object with \"id\" and \"label\""};
      auto s = add(out, e["id"], e["label"], e.contains("quality") ? &e["quality"] : nullptr, where);
      if (!s) return s.error();
    }
  } else if (doc.contains("dataset")) {
    const json* cats = nullptr;
    const json& ds = doc["dataset"];
    if (ds.is_object() && ds.contains("task_attributes") && ds["task_attributes"].is_object() &&
        ds["task_attributes"].contains("categories"))
      cats = &ds["task_attributes"]["categories"];
    if (!cats || !cats->is_array()) return Error{who + ": \"dataset\" has no task_attributes.categories array"};
    for (std::size_t i = 0; i < cats->size(); ++i) {
      const std::string where = who + ": categories[" + std::to_string(i) + "]";
      const json& e = (*cats)[i];
      if (!e.is_object() || !e.contains("id") || !e.contains("name"))
        return Error{where + ": needs an object with \"id\" and \"name\""};
      auto s = add(out, e["id"], e["name"], nullptr, where);
      if (!s) return s.error();
    }
  } else {
    for (auto it = doc.begin(); it != doc.end(); ++it) {
      const std::string where = who + ": key \"" + it.key() + "\"";
      auto s = add(out, json(it.key()), it.value(), nullptr, where);
      if (!s) return s.error();
    }
  }
  std::sort(out.begin(), out.end(),
            [](const ObjectLabel& a, const ObjectLabel& b) { return to_underlying(a.id) < to_underlying(b.id); });
  for (std::size_t i = 1; i < out.size(); ++i)
    if (out[i].id == out[i - 1].id)
      return Error{who + ": object id " + std::to_string(to_underlying(out[i].id)) + " appears twice"};
  return out;
}

Expected<std::vector<ObjectLabel>> read_objects_json(const std::filesystem::path& path) {
  auto bytes = io::read_file_bytes(path);
  if (!bytes) return bytes.error();
  const auto& b = *bytes;
  return parse_objects_json(std::string_view(reinterpret_cast<const char*>(b.data()), b.size()), path.string());
}

}  // namespace gauss
