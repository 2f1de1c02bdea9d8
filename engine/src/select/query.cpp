// Semantic query resolution (class text or instance id -> object set with counts/extents).
#include "gauss/engine/query.h"

#include <algorithm>
#include <cctype>
#include <set>

#include <glm/common.hpp>

namespace gauss {
namespace {

std::string normalized_label(const std::string& s) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  std::string out = s.substr(b, e - b);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

ResolvedObject resolved(const SemanticObject& o) {
  return ResolvedObject{o.id, o.label, o.members.size(), o.centroid, o.extent_min, o.extent_max};
}

}  // namespace

std::string SemanticQuery::describe() const {
  if (kind == Kind::Instance) return "#" + std::to_string(to_underlying(object));
  return "\"" + label + "\"";
}

std::vector<ObjectId> QueryResolution::ids() const {
  std::vector<ObjectId> out;
  out.reserve(objects.size());
  for (const ResolvedObject& o : objects) out.push_back(o.id);
  return out;
}

Expected<QueryResolution> resolve_query(const SemanticQuery& query, std::span<const SemanticObject> objects) {
  QueryResolution r;
  r.query = query;
  if (query.kind == SemanticQuery::Kind::Instance) {
    if (query.object == kNoObject || to_underlying(query.object) < 0) {
      return Error{"query " + query.describe() + ": not an object id"};
    }
    auto it = std::find_if(objects.begin(), objects.end(), [&](const SemanticObject& o) { return o.id == query.object; });
    if (it == objects.end()) {
      return Error{"query " + query.describe() + ": no object with this id (the scene has " +
                   std::to_string(objects.size()) + " objects)"};
    }
    r.objects.push_back(resolved(*it));
  } else {
    const std::string want = normalized_label(query.label);
    if (want.empty()) return Error{"query: empty class text"};
    std::set<std::string> known;
    for (const SemanticObject& o : objects) {
      const std::string have = normalized_label(o.label);
      if (!have.empty()) known.insert(have);
      if (have == want) r.objects.push_back(resolved(o));
    }
    if (r.objects.empty()) {
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      return Error{"query " + query.describe() + ": unknown class (known: " + (list.empty() ? "none" : list) + ")"};
    }
  }
  std::sort(r.objects.begin(), r.objects.end(),
            [](const ResolvedObject& a, const ResolvedObject& b) { return to_underlying(a.id) < to_underlying(b.id); });
  bool any = false;
  for (const ResolvedObject& o : r.objects) {
    r.gaussians += o.gaussians;
    if (o.gaussians == 0) continue;  // an object with no members has no meaningful extent
    r.extent_min = any ? glm::min(r.extent_min, o.extent_min) : o.extent_min;
    r.extent_max = any ? glm::max(r.extent_max, o.extent_max) : o.extent_max;
    any = true;
  }
  return r;
}

}  // namespace gauss
