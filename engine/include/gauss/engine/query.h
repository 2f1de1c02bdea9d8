#pragma once
// Semantic queries: a class query (label text, case-insensitive) resolves to every object
// instance with that label; an instance query names one object id. The resolution says
// which objects, how many appearance Gaussians each holds and where they are, so the
// selector can reserve budget for them and the client can highlight them.
#include <cstddef>
#include <span>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"
#include "gauss/engine/semantic.h"

namespace gauss {

struct SemanticQuery {
  enum class Kind { Class, Instance };
  Kind kind{Kind::Class};
  std::string label;          // Class: matched case-insensitively, surrounding blanks ignored
  ObjectId object{kNoObject};  // Instance

  static SemanticQuery for_class(std::string text) { return {Kind::Class, std::move(text), kNoObject}; }
  static SemanticQuery for_instance(ObjectId id) { return {Kind::Instance, {}, id}; }
  // "chair" or "#7" (instance 7), as typed by a user; for logs and the bench.
  std::string describe() const;
};

struct ResolvedObject {
  ObjectId id{kNoObject};
  std::string label;
  std::size_t gaussians{0};  // appearance members (carriers excluded)
  glm::vec3 centroid{0.0f};
  glm::vec3 extent_min{0.0f};
  glm::vec3 extent_max{0.0f};
};

struct QueryResolution {
  SemanticQuery query;
  std::vector<ResolvedObject> objects;  // sorted by object id, never empty
  std::size_t gaussians{0};             // sum over objects
  glm::vec3 extent_min{0.0f};           // union of the extents of objects with members
  glm::vec3 extent_max{0.0f};
  std::vector<ObjectId> ids() const;    // sorted
};

// Resolves against an object table (SceneStore::objects()). Errors: an empty class text,
// a class no object carries (the message lists the known classes), an instance id not
// in the table, or kNoObject.
Expected<QueryResolution> resolve_query(const SemanticQuery& query, std::span<const SemanticObject> objects);

}  // namespace gauss
