// The controller's vocabulary (common/portable): names by value, and the
// Modbus map's state text made from them.
#include <gtest/gtest.h>

#include <string>

#include "delta/controller/vocabulary.hpp"
#include "delta/modbus/register_map.hpp"

namespace delta::controller {
namespace {

TEST(ControllerVocabularyTest, NamesFollowTheStableNumbers) {
  EXPECT_STREQ(state_name(State::kBoot), "boot");
  EXPECT_STREQ(state_name(State::kFault), "fault");
  EXPECT_STREQ(fault_name(Fault::kNone), "none");
  EXPECT_STREQ(fault_name(Fault::kHeartbeatLost), "heartbeat lost");
  EXPECT_STREQ(fault_name(Fault::kFeedbackLate), "feedback late");
  EXPECT_STREQ(fault_name(Fault::kCollision), "collision");
  EXPECT_STREQ(trajectory_fault_name(TrajectoryFault::kOutsideWorkspace), "outside the workspace");
  // A number the vocabulary does not know (a newer controller's) is named so.
  EXPECT_STREQ(fault_name(static_cast<Fault>(15)), "unknown");
  EXPECT_STREQ(state_name(static_cast<State>(200)), "unknown");
}

TEST(ControllerVocabularyTest, TheModbusMapDescribesItsRegistersWithTheNames) {
  EXPECT_EQ(std::string(modbus::named("state").description),
            "0 boot, 1 configuring, 2 ready, 3 running, 4 stopping, 5 fault");
  EXPECT_EQ(std::string(modbus::named("trajectory").description),
            "0 path1, 1 path2, 2 pick-and-place, 3 custom; not while running");
}

TEST(ControllerVocabularyTest, TrajectoriesByNameAndId) {
  TrajectoryId id{};
  ASSERT_TRUE(trajectory_id("pick-and-place", id));
  EXPECT_EQ(id, TrajectoryId::kPickAndPlace);
  EXPECT_STREQ(trajectory_name(TrajectoryId::kPath2), "path2");
  EXPECT_FALSE(trajectory_id("figure8", id));
  EXPECT_FALSE(trajectory_id("path", id));
  ASSERT_TRUE(trajectory_id("custom", id));
  EXPECT_EQ(id, TrajectoryId::kCustom);
  EXPECT_STREQ(trajectory_name(static_cast<TrajectoryId>(4)), "unknown");
}

}  // namespace
}  // namespace delta::controller
