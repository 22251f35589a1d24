// Control on an elastic robot, in one process (docs/using-the-model.md,
// "Elastic gearboxes"). The robot of tests/data/robots/elastic.json has
// gearboxes of 3000, 3400 and 2700 N m/rad with the encoders on the motors,
// torque constants 6 %, -5 % and +10 % off and currents filtered at 0.5 ms.
// Its path1 is recorded through the firmware's port and fitted as `host_id
// fit --gearbox-stiffness 3000` fits it (one datasheet value for the three
// gearboxes, up to 11 % off each); the controller runs pick-and-place with
// the nominal feed-forward and with the identified model, and the emulator
// measures the arms' own tracking (its `arm tracking` line), which the
// controller cannot see.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>

#include "chain_runs.hpp"
#include "delta/identified_model.hpp"
#include "delta/model_q.hpp"
#include "delta/robot_description.hpp"
#include "host_id/identify.hpp"
#include "host_id/model_selection.hpp"
#include "host_id/model_transfer.hpp"
#include "host_id/report.hpp"
#include "in_process_rig.hpp"

namespace fw_linux {
namespace {

emu::EmulatorConfig robot(const char* file) {
  emu::EmulatorConfig ec;
  ec.plant = emu::PlantKind::kMujoco;
  ec.robot = delta::read_robot_description(std::string(DELTA_ROBOTS_DIR "/") + file);
  ec.geometry = ec.robot.geometry;
  return ec;
}

// The default fit of the recorded log (--model auto's variant, least
// squares) with the gearboxes' stiffness given, saved and read back as a
// user's RESULT.json.
delta::IdentifiedModel fitted_model(const host_id::DeltaLog& log, double stiffness_Nm_per_rad) {
  host_id::FitOptions o;
  o.method = host_id::Method::kLeastSquares;
  const host_id::ModelSelection s = host_id::select_model(log, o);
  o.model = s.variants[s.chosen].model;
  o.model.gearbox_compliance_rad_per_Nm.fill(1.0 / stiffness_Nm_per_rad);
  const host_id::FitResult fit = host_id::fit_log(log, o);
  const std::string path = ::testing::TempDir() + "elastic_model.json";
  {
    std::ofstream out(path);
    out << host_id::json_report(fit).dump(2);
  }
  return delta::read_identified_model(path);
}

struct Tracking {
  std::array<double, 3> motor_rms_rad{};  // the controller's `tracking`
  std::array<double, 3> arm_rms_rad{};    // the emulator's `arm tracking`
  std::array<double, 3> motor_max_rad{};
  std::array<double, 3> arm_max_rad{};
  double worst_arm() const { return *std::max_element(arm_rms_rad.begin(), arm_rms_rad.end()); }
};

Tracking pick_and_place(const PortConfig& c, emu::EmulatorConfig ec) {
  Tracking t;
  int lines = 0;
  ec.report = [&](const std::string& line) {
    lines += std::sscanf(line.c_str(), "arm tracking: rms_rad=%lf,%lf,%lf max_rad=%lf,%lf,%lf",
                         &t.arm_rms_rad[0], &t.arm_rms_rad[1], &t.arm_rms_rad[2], &t.arm_max_rad[0],
                         &t.arm_max_rad[1], &t.arm_max_rad[2]) == 6;
  };
  Rig rig(c, ec);
  run_trajectory(rig, "pick-and-place", nullptr);
  const fw::TrackingStats& s = rig.controller.tracking();
  for (unsigned j = 0; j < 3; ++j) {
    t.motor_rms_rad[j] =
        std::sqrt(std::ldexp(static_cast<double>(s.sum_sq_rad2_q40[j]), -40) / s.ticks);
    t.motor_max_rad[j] = std::ldexp(static_cast<double>(s.max_abs_rad[j].raw()), -28);
  }
  EXPECT_EQ(lines, 1) << "one `arm tracking` line after the run";
  return t;
}

PortConfig with(fw::FeedForwardMode mode, const std::optional<delta::IdentifiedModel>& m = {}) {
  PortConfig c = Rig::config();
  c.feed_forward = mode;
  c.feed_forward_model = m;
  return c;
}

void print(const char* name, const Tracking& t) {
  std::printf("%-34s tracking rms %.3g, %.3g, %.3g  arm tracking rms %.3g, %.3g, %.3g mrad\n", name,
              1e3 * t.motor_rms_rad[0], 1e3 * t.motor_rms_rad[1], 1e3 * t.motor_rms_rad[2],
              1e3 * t.arm_rms_rad[0], 1e3 * t.arm_rms_rad[1], 1e3 * t.arm_rms_rad[2]);
}

// On a rigid robot the arms are where the motors' encoders say: the
// emulator's line over the same span is the controller's own, to the
// encoders' and the reference's quantisation.
TEST(ChainElastic, OnARigidRobotTheArmsTrackingIsTheControllers) {
  emu::EmulatorConfig ec;  // the lumped default robot
  const Tracking t = pick_and_place(with(fw::FeedForwardMode::kNominal), ec);
  print("rigid robot, nominal", t);
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_NEAR(t.arm_rms_rad[j], t.motor_rms_rad[j], 0.01 * t.motor_rms_rad[j]) << j;
    EXPECT_NEAR(t.arm_max_rad[j], t.motor_max_rad[j], 0.02 * t.motor_max_rad[j]) << j;
  }
}

TEST(ChainElastic, CompensationPutsTheIdentifiedModelsGainOnTheArm) {
  const emu::EmulatorConfig ec = robot("elastic.json");
  const host_id::DeltaLog log = record_path1(ec).log;
  ASSERT_GT(log.size(), 7000u);
  const delta::IdentifiedModel model = fitted_model(log, 3000.0);
  // As `host_id model show` reads it back from the controller's record.
  delta::controller::ModelRecordBytes bytes{};
  delta::controller::encode_model_record(delta::model_record(model), bytes);
  delta::controller::ModelRecord record;
  ASSERT_EQ(delta::controller::decode_model_record(bytes, record),
            delta::controller::ModelRecordFault::kOk);
  std::ostringstream shown;
  host_id::print_model({2, model.fit_id, delta::identified_model(record)}, shown);
  EXPECT_NE(
      shown.str().find("gearbox_stiffness                3000         3000         3000 N m/rad"),
      std::string::npos)
      << shown.str();
  const Tracking nominal = pick_and_place(with(fw::FeedForwardMode::kNominal), ec);
  const Tracking compensated = pick_and_place(with(fw::FeedForwardMode::kModel, model), ec);
  PortConfig off = with(fw::FeedForwardMode::kModel, model);
  off.deflection_compensation = false;
  const Tracking uncompensated = pick_and_place(off, ec);
  print("nominal feed-forward", nominal);
  print("identified, compensated", compensated);
  print("identified, compensation off", uncompensated);
  const double gain = nominal.worst_arm() / compensated.worst_arm();
  const double gain_off = nominal.worst_arm() / uncompensated.worst_arm();
  std::printf(
      "worst joint's arm tracking, nominal over identified: %.2f (compensation off: %.2f)\n", gain,
      gain_off);
  EXPECT_GE(gain, 4.0);
  // What compensation itself does: the arm follows the motor's tracking
  // instead of lagging it by the deflection (the worst joint's, measured:
  // 0.86 of it with compensation off).
  EXPECT_LT(compensated.worst_arm(), 0.92 * uncompensated.worst_arm());
}

}  // namespace
}  // namespace fw_linux
