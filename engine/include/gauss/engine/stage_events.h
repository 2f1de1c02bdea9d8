#pragma once
// Stage events: every edit batch and every query leaves a trail of timestamped stages,
// written as JSON lines, so delivery, desired state, publication and display are
// measured separately (the paper's observability section).
//   batch stages: available (host), sent, received, desired, queued, published,
//                 first_frame (first frame rendered with it)
//   query stages: resolved, target, initial_residency, desired_residency,
//                 first_additional, converged, highlight
#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "gauss/engine/ids.h"
#include "gauss/engine/result.h"

namespace gauss {

enum class BatchStage : std::uint8_t { Available, Sent, Received, Desired, Queued, Published, FirstFrame };
enum class QueryStage : std::uint8_t {
  Resolved,          // the host resolved the query text/id to objects
  Target,            // target identity (object ids) known
  InitialResidency,  // target members resident when the query took effect
  DesiredResidency,  // target members the selection wants resident
  FirstAdditional,   // first frame with more target content resident than initially
  Converged,         // published target residency reached the desired one
  Highlight,         // first frame showing the highlight
};

const char* to_string(BatchStage s);
const char* to_string(QueryStage s);

struct StageEvent {
  double t{0.0};              // seconds (virtual in the simulation)
  std::uint32_t client{0};
  bool is_query{false};
  std::uint8_t stage{0};      // BatchStage or QueryStage
  std::uint64_t epoch{0};     // batch: its epoch
  std::uint64_t count{0};     // batch: edits at this stage; query: resident/desired members
  std::uint32_t query{0};     // query: its sequence number
  std::int32_t object{-1};    // query: target object (first one for a class query)
  std::uint64_t frame{0};     // display frame index where the stage is frame-bound
};

class EventLog {
 public:
  void batch(double t, std::uint32_t client, Epoch epoch, BatchStage stage, std::uint64_t count,
             std::uint64_t frame = 0);
  void query(double t, std::uint32_t client, std::uint32_t query, QueryStage stage, ObjectId object,
             std::uint64_t count, std::uint64_t frame = 0);

  const std::vector<StageEvent>& events() const noexcept { return events_; }
  void clear() { events_.clear(); }
  // First event matching, or nullptr.
  const StageEvent* find_batch(std::uint32_t client, Epoch epoch, BatchStage stage) const;
  const StageEvent* find_query(std::uint32_t client, std::uint32_t query, QueryStage stage) const;

  // One JSON object per line, e.g.
  // {"t":1.25,"client":0,"kind":"batch","stage":"received","epoch":7,"count":1200}
  static std::string to_json_line(const StageEvent& e);
  static Expected<StageEvent> from_json_line(const std::string& line);
  void write_jsonl(std::ostream& out) const;

 private:
  std::vector<StageEvent> events_;
};

}  // namespace gauss
