// Collision detection in one process (docs/safety.md), the controller
// started with the model `host_id fit` fits by default from the recorded
// path1 (--model auto, saved and read back) and the thresholds it carries,
// the detector on as it comes; contacts on the platform in several
// directions at 2 s (holding), 3 s (at speed) and 5 s (accelerating) of
// the pick-and-place, each of 200 ms, their detection timed from onset.
// - The multibody robot (rigid, ideal drives: the HIL suite's robot,
//   which runs a few of these contacts on vcan): two clean runs, the
//   current noise seeded apart, end with no detection; 10 N in each of
//   five directions at each moment is detected within 10 ms.
// - The drive-train robot of tests/data/robots/drive_train.json: elastic
//   gearboxes (2700-3400 N m/rad), torque constants 5-10 % off, currents
//   filtered, load friction and cogging, none of which the controller's
//   model runs; the thresholds scaled by 2 (collision.threshold_scale) as
//   docs/safety.md says for elastic gearboxes. Three clean runs; 20 N in
//   three directions at each moment, within 20 ms (measured: 6-12 ms).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "chain_runs.hpp"
#include "delta/identified_model.hpp"
#include "delta/robot_description.hpp"
#include "fw_linux/trajectories.hpp"
#include "host_id/fit_auto.hpp"
#include "host_id/identify.hpp"
#include "host_id/report.hpp"
#include "in_process_rig.hpp"

namespace fw_linux {
namespace {

// The multibody robot of `robot` (default: the built-in one).
emu::EmulatorConfig multibody_robot(
    const delta::RobotDescription& robot = delta::default_robot_description()) {
  emu::EmulatorConfig ec;
  ec.plant = emu::PlantKind::kMujoco;
  ec.robot = robot;
  ec.geometry = ec.robot.geometry;
  return ec;
}

// The default fit of the recorded path1 (--model auto, least squares: the
// optimum PSO reaches; its cogging terms, where it takes them, the
// controller leaves out), saved and read back as a user's RESULT.json.
delta::IdentifiedModel fitted_model(const host_id::DeltaLog& log, const std::string& name) {
  host_id::FitOptions o;
  o.method = host_id::Method::kLeastSquares;
  const host_id::FitResult fit = host_id::fit_auto(
                                     log, [&log] { return log; }, o)
                                     .result;
  const std::string path = ::testing::TempDir() + name + "_model.json";
  {
    std::ofstream out(path);
    out << host_id::json_report(fit).dump(2);
  }
  return delta::read_identified_model(path);
}

PortConfig with_model(const delta::IdentifiedModel& m, double threshold_scale) {
  PortConfig c = Rig::config();
  c.feed_forward = fw::FeedForwardMode::kModel;
  c.feed_forward_model = m;
  c.collision_threshold_scale = threshold_scale;
  return c;
}

// One pick-and-place with a contact from `spec` (the emulator's
// --inject contact:...): the milliseconds from its onset to the detection;
// negative where the run ended without one.
double detection_ms(const PortConfig& c, emu::EmulatorConfig ec, const std::string& spec) {
  double contact_s = -1.0;
  ec.faults = {emu::parse_fault(spec)};
  ec.report = [&](const std::string& line) {
    std::sscanf(line.c_str(), "contact: t_s=%lf", &contact_s);
  };
  Rig rig(c, ec);
  for (int i = 0; i < 2000 && rig.controller.state() != fw::State::kReady; ++i) rig.cycle();
  const auto trajectory = named_trajectory("pick-and-place", c);
  if (!trajectory || !rig.controller.start(*trajectory).accepted) return -1.0;
  for (int i = 0; i < 20000; ++i) {
    rig.cycle();
    if (rig.controller.fault() == fw::Fault::kCollision) {
      const double t_s = static_cast<double>(rig.master.syncs_sent() - 1) * c.period_us * 1e-6;
      return contact_s >= 0.0 ? (t_s - contact_s) * 1e3 : -1.0;
    }
    if (rig.controller.state() == fw::State::kReady) break;
  }
  return -1.0;
}

// Each contact of `force_N` in each of `directions` at 2, 3 and 5 s is
// detected within `bar_ms`; the worst delay [ms].
double worst_detection_ms(const PortConfig& c, const emu::EmulatorConfig& ec, const char* force_N,
                          const std::vector<const char*>& directions, double bar_ms) {
  double worst_ms = 0.0;
  for (const char* at : {"2", "3", "5"}) {
    for (const char* direction : directions) {
      const std::string spec = std::string("contact:") + force_N + ":" + direction + ":200@" + at;
      const double ms = detection_ms(c, ec, spec);
      std::printf("%s: detected after %.0f ms\n", spec.c_str(), ms);
      EXPECT_GE(ms, 0.0) << spec;
      EXPECT_LE(ms, bar_ms + 1e-6) << spec;
      worst_ms = std::max(worst_ms, ms);
    }
  }
  return worst_ms;
}

TEST(ChainCollision, OnTheMultibodyRobotNoFalseAlarmAndTenNewtonsWithinTenMilliseconds) {
  const emu::EmulatorConfig ec = multibody_robot();
  const host_id::DeltaLog log = record_path1(ec).log;
  ASSERT_GT(log.size(), 7000u);
  const delta::IdentifiedModel model = fitted_model(log, "multibody");
  ASSERT_TRUE(model.collision_thresholds.has_value());
  const PortConfig c = with_model(model, 1.0);
  for (const std::uint64_t seed : {2u, 3u}) {
    emu::EmulatorConfig noise = ec;
    noise.seed = seed;
    Rig rig(c, noise);
    ASSERT_TRUE(rig.controller.collision_config().detect);
    run_trajectory(rig, "pick-and-place", nullptr);
    EXPECT_EQ(rig.controller.fault(), fw::Fault::kNone) << "clean run, noise seed " << seed;
  }
  const double worst_ms =
      worst_detection_ms(c, ec, "10", {"1,0,0", "-1,0,0", "0,1,0", "0,-1,0", "0,0,-1"}, 10.0);
  std::printf("15 contacts of 10 N on the multibody robot: detected within %.0f ms\n", worst_ms);
}

TEST(ChainCollision, OnTheDriveTrainRobotNoFalseAlarmAndContactsWithinTwentyMilliseconds) {
  const emu::EmulatorConfig ec =
      multibody_robot(delta::read_robot_description(DELTA_ROBOTS_DIR "/drive_train.json"));
  const host_id::DeltaLog log = record_path1(ec).log;
  ASSERT_GT(log.size(), 7000u);
  const delta::IdentifiedModel model = fitted_model(log, "drive_train");
  ASSERT_TRUE(model.collision_thresholds.has_value());
  // The elastic gearboxes ring at the pick-and-place's stops, which the
  // fitted Fourier log does not show: at 1 the residual reached 1.08 of the
  // thresholds (a false stop), at 1.25 too; 2 is the scale docs/safety.md
  // gives for such a robot.
  const PortConfig c = with_model(model, 2.0);
  Rig rig(c, ec);
  ASSERT_TRUE(rig.controller.collision_config().detect);
  for (int run = 0; run < 3; ++run) {
    run_trajectory(rig, "pick-and-place", nullptr);
    EXPECT_EQ(rig.controller.fault(), fw::Fault::kNone) << "clean run " << run + 1;
  }
  const double worst_ms = worst_detection_ms(c, ec, "20", {"1,0,0", "0,-1,0", "0,0,-1"}, 20.0);
  std::printf("9 contacts of 20 N on the drive-train robot: detected within %.0f ms\n", worst_ms);
}

}  // namespace
}  // namespace fw_linux
