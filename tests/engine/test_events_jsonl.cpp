// Stage events: JSON lines round-trip, and malformed lines are rejected with a reason.
#include <gtest/gtest.h>

#include <sstream>

#include "gauss/engine/stage_events.h"

using namespace gauss;

TEST(StageEvents, JsonLinesRoundTrip) {
  EventLog log;
  log.batch(1.5, 2, Epoch{7}, BatchStage::Received, 1200);
  log.batch(1.75, 2, Epoch{7}, BatchStage::FirstFrame, 1200, 126);
  log.query(2.0, 1, 3, QueryStage::DesiredResidency, ObjectId{5}, 4000);
  std::ostringstream out;
  log.write_jsonl(out);
  std::istringstream in(out.str());
  std::string line;
  std::vector<StageEvent> back;
  while (std::getline(in, line)) {
    auto e = EventLog::from_json_line(line);
    ASSERT_TRUE(e.ok()) << e.message();
    back.push_back(*e);
  }
  ASSERT_EQ(back.size(), 3u);
  EXPECT_EQ(back[0].epoch, 7u);
  EXPECT_EQ(back[0].stage, static_cast<std::uint8_t>(BatchStage::Received));
  EXPECT_EQ(back[1].frame, 126u);
  EXPECT_TRUE(back[2].is_query);
  EXPECT_EQ(back[2].object, 5);
  EXPECT_EQ(back[2].count, 4000u);
  EXPECT_NE(out.str().find("\"stage\":\"desired_residency\""), std::string::npos);
  ASSERT_NE(log.find_batch(2, Epoch{7}, BatchStage::FirstFrame), nullptr);
  EXPECT_EQ(log.find_batch(2, Epoch{8}, BatchStage::FirstFrame), nullptr);
  ASSERT_NE(log.find_query(1, 3, QueryStage::DesiredResidency), nullptr);
}

TEST(StageEvents, MalformedLinesAreRejected) {
  for (const char* bad : {"", "[1,2]", "{\"kind\":\"batch\"}", "{\"kind\":\"x\",\"stage\":\"sent\"}",
                          "{\"kind\":\"batch\",\"stage\":\"teleported\",\"t\":0,\"client\":0,\"count\":0,\"frame\":0,\"epoch\":1}",
                          "{\"kind\":\"batch\",\"stage\":\"sent\",\"t\":\"soon\",\"client\":0,\"count\":0,\"frame\":0,\"epoch\":1}",
                          "{\"kind\":\"query\",\"stage\":\"target\",\"t\":0,\"client\":0,\"count\":0,\"frame\":0}"}) {
    auto e = EventLog::from_json_line(bad);
    EXPECT_FALSE(e.ok()) << bad;
    if (!e.ok()) {
      EXPECT_NE(e.message().find("stage event"), std::string::npos);
    }
  }
}
