// Runs through the run coordinator on the in-process rig, as delta_fw runs
// them: the tracking line after each, and a run checked before a model was
// loaded.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include "delta/model_q.hpp"
#include "fw/controller.hpp"
#include "fw_linux/canopen_master.hpp"
#include "fw_linux/exit_codes.hpp"
#include "fw_linux/run_coordinator.hpp"
#include "fw_linux/trajectories.hpp"
#include "in_process_rig.hpp"
#include "port_test_support.hpp"

namespace fw_linux {
namespace {

// path2, checked at start as `delta_fw --run path2` checks it.
std::vector<NamedRun> path2_checked_at_start(const fw::ControllerConfig& core) {
  const auto traj = named_trajectory("path2", Rig::config());
  EXPECT_TRUE(traj.has_value());
  std::vector<NamedRun> runs;
  if (traj) {
    runs.push_back({"path2", fw::CheckedTrajectory::check(fw::trajectory_bounds(core), *traj)});
  }
  return runs;
}

// Cycles the rig until the coordinator has an exit code (at most 20 000).
void run_until_exit(Rig& rig, RunCoordinator& coordinator) {
  for (int i = 0; i < 20000 && !coordinator.exit_code(); ++i) {
    rig.cycle();
    coordinator.after_step(rig.controller, rig.hw, rig.master);
  }
}

// After each run delta_fw prints `tracking NAME: rms_rad=a,b,c
// max_rad=a,b,c`, the controller's own statistics over the trajectory.
TEST(InProcessPortTest, EachRunEndsWithItsTrackingLine) {
  Rig rig;
  std::ostringstream messages;
  const fw::ControllerConfig core = controller_config(Rig::config());
  RunCoordinator coordinator(path2_checked_at_start(core), true, nullptr, messages);
  run_until_exit(rig, coordinator);
  ASSERT_EQ(coordinator.exit_code(), kExitDone) << messages.str();
  const std::string text = messages.str();
  const std::size_t at = text.find("\ntracking path2: rms_rad=");
  ASSERT_NE(at, std::string::npos) << text;
  std::array<double, 3> rms{}, largest{};
  ASSERT_EQ(
      std::sscanf(text.c_str() + at + 1, "tracking path2: rms_rad=%lf,%lf,%lf max_rad=%lf,%lf,%lf",
                  &rms[0], &rms[1], &rms[2], &largest[0], &largest[1], &largest[2]),
      6)
      << text;
  const fw::TrackingStats& t = rig.controller.tracking();
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_GT(rms[j], 0.0);
    EXPECT_LT(rms[j], largest[j]);
    EXPECT_LT(largest[j], 0.02);  // as the run test above measures through the bus
    EXPECT_NEAR(largest[j], std::ldexp(t.max_abs_rad[j].raw(), -28), 1e-5 * largest[j]);  // %.6g
  }
}

// A command-line run checked at start, then a model loaded before it
// starts: the controller refuses it (its check covered another
// feed-forward, and a check's walk does not belong in the control loop),
// and delta_fw says why and what to do.
TEST(InProcessPortTest, ARunCheckedBeforeAModelWasLoadedIsRefusedWithItsReason) {
  Rig rig;
  std::ostringstream messages;
  const fw::ControllerConfig core = controller_config(Rig::config());
  RunCoordinator coordinator(path2_checked_at_start(core), true, nullptr, messages);
  delta::IdentifiedModel m;
  m.kind = "lumped";
  m.geometry = delta::kDefaultGeometry;
  m.parameters = delta::to_high_fidelity(delta::default_lumped_parameters());
  fw::FeedForwardConfig model = core.feed_forward;
  model.mode = fw::FeedForwardMode::kModel;
  model.model = delta::fx::prepare_model(core.geometry, delta::model_parameters_q(m));
  ASSERT_TRUE(rig.controller.set_feed_forward(model));  // before the first cycle: boot
  run_until_exit(rig, coordinator);
  EXPECT_EQ(coordinator.exit_code(), kExitRejected);
  EXPECT_NE(messages.str().find("trajectory 'path2' rejected: it was checked at start against "
                                "another feed-forward (a model was loaded since); start "
                                "delta_fw again"),
            std::string::npos)
      << messages.str();
}

}  // namespace
}  // namespace fw_linux

namespace fw_linux {
namespace {

// The gear is 10:1, the controller is told 2.5:1 (a counts_per_rev the
// bring-up cannot check against 0x608F would do the same): every angle
// reads 4 times too far, joint limit at the run's first cycle. delta_fw
// names the joint, its angle and what to check.
TEST(InProcessPortTest, AJointOutsideItsRangeIsNamedWithWhatToCheck) {
  PortConfig c = Rig::config();
  for (auto& j : c.joints) j.model.gear_ratio = 2.5;
  Rig rig(c, {});
  std::ostringstream messages;
  RunCoordinator coordinator(path2_checked_at_start(controller_config(c)), true, nullptr, messages);
  run_until_exit(rig, coordinator);
  EXPECT_EQ(coordinator.exit_code(), kExitFault) << messages.str();
  EXPECT_NE(messages.str().find("fault 4 (joint limit): joint 1 at 1.8 rad, outside [-1.2, 1.4] "
                                "rad; if the arm is not there, the drive's position is read with "
                                "the wrong scale or zero: check joint1.counts_per_rev (the "
                                "drive's 0x608F:1), joint1.gear_ratio and joint1.zero_rad"),
            std::string::npos)
      << messages.str();
}

}  // namespace
}  // namespace fw_linux
