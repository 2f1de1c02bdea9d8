#include "gauss/engine/stage_events.h"

#include <array>
#include <ostream>

#include <nlohmann/json.hpp>

namespace gauss {

namespace {
constexpr std::array<const char*, 7> kBatchNames{"available", "sent", "received", "desired", "queued", "published", "first_frame"};
constexpr std::array<const char*, 7> kQueryNames{"resolved", "target", "initial_residency", "desired_residency",
                                                 "first_additional", "converged", "highlight"};
}  // namespace

const char* to_string(BatchStage s) {
  const auto i = static_cast<std::size_t>(s);
  return i < kBatchNames.size() ? kBatchNames[i] : "unknown";
}
const char* to_string(QueryStage s) {
  const auto i = static_cast<std::size_t>(s);
  return i < kQueryNames.size() ? kQueryNames[i] : "unknown";
}

void EventLog::batch(double t, std::uint32_t client, Epoch epoch, BatchStage stage, std::uint64_t count,
                     std::uint64_t frame) {
  StageEvent e;
  e.t = t;
  e.client = client;
  e.stage = static_cast<std::uint8_t>(stage);
  e.epoch = to_underlying(epoch);
  e.count = count;
  e.frame = frame;
  events_.push_back(e);
}

void EventLog::query(double t, std::uint32_t client, std::uint32_t query, QueryStage stage, ObjectId object,
                     std::uint64_t count, std::uint64_t frame) {
  StageEvent e;
  e.t = t;
  e.client = client;
  e.is_query = true;
  e.stage = static_cast<std::uint8_t>(stage);
  e.query = query;
  e.object = to_underlying(object);
  e.count = count;
  e.frame = frame;
  events_.push_back(e);
}

const StageEvent* EventLog::find_batch(std::uint32_t client, Epoch epoch, BatchStage stage) const {
  for (const auto& e : events_)
    if (!e.is_query && e.client == client && e.epoch == to_underlying(epoch) && e.stage == static_cast<std::uint8_t>(stage))
      return &e;
  return nullptr;
}

const StageEvent* EventLog::find_query(std::uint32_t client, std::uint32_t query, QueryStage stage) const {
  for (const auto& e : events_)
    if (e.is_query && e.client == client && e.query == query && e.stage == static_cast<std::uint8_t>(stage)) return &e;
  return nullptr;
}

std::string EventLog::to_json_line(const StageEvent& e) {
  nlohmann::json j;
  j["t"] = e.t;
  j["client"] = e.client;
  j["kind"] = e.is_query ? "query" : "batch";
  j["stage"] = e.is_query ? to_string(static_cast<QueryStage>(e.stage)) : to_string(static_cast<BatchStage>(e.stage));
  if (e.is_query) {
    j["query"] = e.query;
    j["object"] = e.object;
  } else {
    j["epoch"] = e.epoch;
  }
  j["count"] = e.count;
  j["frame"] = e.frame;
  return j.dump();
}

Expected<StageEvent> EventLog::from_json_line(const std::string& line) {
  auto j = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded() || !j.is_object()) return Error{"stage event: not a JSON object: " + line.substr(0, 80)};
  auto num = [&j](const char* key, auto& out) -> bool {
    auto it = j.find(key);
    if (it == j.end() || !it->is_number()) return false;
    out = it->get<std::remove_reference_t<decltype(out)>>();
    return true;
  };
  StageEvent e;
  auto kind = j.find("kind");
  auto stage = j.find("stage");
  if (kind == j.end() || !kind->is_string() || stage == j.end() || !stage->is_string())
    return Error{"stage event: missing \"kind\" or \"stage\": " + line.substr(0, 80)};
  e.is_query = kind->get<std::string>() == "query";
  if (!e.is_query && kind->get<std::string>() != "batch") return Error{"stage event: unknown kind " + kind->dump()};
  const std::string s = stage->get<std::string>();
  bool found = false;
  const auto& names = e.is_query ? kQueryNames : kBatchNames;
  for (std::size_t i = 0; i < names.size(); ++i)
    if (s == names[i]) {
      e.stage = static_cast<std::uint8_t>(i);
      found = true;
    }
  if (!found) return Error{"stage event: unknown stage \"" + s + "\""};
  if (!num("t", e.t) || !num("client", e.client) || !num("count", e.count) || !num("frame", e.frame))
    return Error{"stage event: missing numeric t/client/count/frame: " + line.substr(0, 80)};
  if (e.is_query ? !(num("query", e.query) && num("object", e.object)) : !num("epoch", e.epoch))
    return Error{"stage event: missing query/object or epoch: " + line.substr(0, 80)};
  return e;
}

void EventLog::write_jsonl(std::ostream& out) const {
  for (const auto& e : events_) out << to_json_line(e) << '\n';
}

}  // namespace gauss
