#pragma once
// Object table sidecar: object id -> class label (and optional observation quality).
//
// Accepted forms (UTF-8 JSON):
//   {"objects": [{"id": 3, "label": "chair", "quality": 0.8}, ...]}   quality optional (1.0)
//   {"3": "chair", "7": "table"}                                         plain map
//   a segments.ai export: {"dataset": {"task_attributes": {"categories":
//                                    [{"id": 1, "name": "Category 1"}, ...]}}}
// Errors name the input and what is wrong: malformed JSON (with its byte offset), a missing
// or mistyped field (naming the entry), an id that is negative or not an int32, an empty
// label, a quality outside [0, 1], a repeated id.
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"

namespace gauss {

struct ObjectLabel {
  ObjectId id{kNoObject};
  std::string label;
  float quality{1.0f};
};

// Sorted by id.
Expected<std::vector<ObjectLabel>> parse_objects_json(std::string_view text, std::string_view name);
Expected<std::vector<ObjectLabel>> read_objects_json(const std::filesystem::path& path);

}  // namespace gauss
