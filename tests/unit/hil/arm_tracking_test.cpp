// The emulator's `arm tracking` line (emu/arm_tracking.hpp): the span is
// the controller's `tracking` line's, after the approach and before the
// stop, and the line comes once all three drives' runs ended.
#include "emu/arm_tracking.hpp"

#include <gtest/gtest.h>

namespace emu {
namespace {

TEST(ArmTrackingTest, CoversTheTrajectoryBetweenTheApproachAndTheStop) {
  ArmTracking t(3, 2);
  // approach 3 cycles (errors 9), trajectory 4 (errors 1, -2, 2, -1 on
  // joint 1), stop 2 (errors 9).
  const double joint1[] = {9, 9, 9, 1, -2, 2, -1, 9, 9};
  for (const double e : joint1) {
    t.add(0, e);
    t.add(1, e / 1000);
    t.add(2, 0.0);
  }
  EXPECT_FALSE(t.end(0).has_value());
  EXPECT_FALSE(t.end(1).has_value());
  EXPECT_FALSE(t.end(1).has_value());  // already ended
  const auto line = t.end(2);
  ASSERT_TRUE(line.has_value());
  // rms sqrt((1 + 4 + 4 + 1) / 4) = 1.58114, max 2.
  EXPECT_EQ(*line, "arm tracking: rms_rad=1.58114,0.00158114,0 max_rad=2,0.002,0");
  // The next run starts afresh.
  for (int i = 0; i < 6; ++i) {
    for (unsigned j = 0; j < 3; ++j) t.add(j, 0.5);
  }
  t.end(0);
  t.end(1);
  EXPECT_EQ(*t.end(2), "arm tracking: rms_rad=0.5,0.5,0.5 max_rad=0.5,0.5,0.5");
}

TEST(ArmTrackingTest, ARunThatEndedInTheApproachHasNoLine) {
  ArmTracking t(3, 2);
  for (unsigned j = 0; j < 3; ++j) t.add(j, 1.0);
  t.end(0);
  t.end(1);
  EXPECT_FALSE(t.end(2).has_value());
}

}  // namespace
}  // namespace emu
