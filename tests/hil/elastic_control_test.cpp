// Control on an elastic robot on vcan (docs/using-the-model.md, "Elastic
// gearboxes"), with the real programs in lock-step: the emulator's MuJoCo
// robot of tests/data/robots/elastic.json has gearboxes of 3000, 3400 and
// 2700 N m/rad with the encoders on the motors, torque constants 6 %, -5 %
// and +10 % off and currents filtered at 0.5 ms. path1 (one period) is
// recorded, fitted with the gearboxes' datasheet stiffness (one value, 3000
// N m/rad, up to 11 % off each), and the pick-and-place run with the
// nominal feed-forward and with the fitted model: the emulator's `arm tracking` line, the arms'
// own error that the controller cannot see, is at least 4 times lower.
// path1 is recorded with arm_encoders = true: each drive's 0x60E4:1 in its
// TPDO4, the controller's LOG_D and LOG_E, the recorder's qa1..qa3, from
// which `fit --elastic` finds each gearbox's stiffness.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "pipeline_programs.hpp"
#include "scratch_directory.hpp"

namespace {

using hil::kBin;
using hil::kIface;
using hil::kSource;
using hil::worst_arm_tracking;
using namespace std::chrono_literals;

// One pick-and-place cycle (of the trajectory's three: the VM's time; the
// in-process ChainElastic runs all three) with `sets`; delta_fw's words.
std::string pick_and_place(const std::vector<std::string>& sets) {
  std::vector<std::string> argv{kBin + "/delta_fw", "--can", kIface,
                                "--lockstep",       "--run", "pick-and-place:1",
                                "--exit-when-done", "--set", "feed_forward.store="};
  argv.insert(argv.end(), sets.begin(), sets.end());
  hil::Child fw = hil::Child::spawn(argv);
  EXPECT_EQ(fw.wait(300s).value_or(-1), 0) << fw.err();
  return fw.err() + fw.out();
}

// The stiffness `fit --elastic` finds from the arm-side encoders of a
// recorded log: in the drive's torque units, so the robot file's stiffness
// over its torque constant ratio (the deflection is k tau_drive / K). The
// log carries little deflection (a few encoder counts): 0.3-0.8 % measured,
// the bar 5 %.
void expect_stiffness_from_arm_encoders(const std::string& dir) {
  std::ifstream log(dir + "/path1.csv");
  std::string line;
  while (std::getline(log, line) && line.starts_with("#")) {
  }
  EXPECT_TRUE(line.ends_with(",qa1,qa2,qa3")) << "the recorded log's columns: " << line;
  hil::Child fit = hil::Child::spawn({kBin + "/host_id", "fit", dir + "/path1.csv", "--elastic",
                                      "--json", "--out", dir + "/elastic.json", "--quiet"});
  ASSERT_EQ(fit.wait(300s).value_or(-1), 0) << fit.err();
  std::ifstream robot_file(kSource + "/tests/data/robots/elastic.json");
  const nlohmann::json robot = nlohmann::json::parse(robot_file);
  std::ifstream fitted_file(dir + "/elastic.json");
  const nlohmann::json e = nlohmann::json::parse(fitted_file).at("elasticity");
  ASSERT_TRUE(e.at("from_arm_encoders").get<bool>());
  for (unsigned j = 0; j < 3; ++j) {
    const nlohmann::json& joint = robot.at("joints").at(j);
    const double truth = joint.at("gearbox_stiffness_Nm_per_rad").get<double>() /
                         joint.at("torque_constant_ratio").get<double>();
    const double found = 1.0 / e.at("compliance_rad_per_Nm").at(j).get<double>();
    std::cout << "joint " << j + 1 << ": K from the arm encoders over CAN " << found
              << " N m/rad, truth in drive units " << truth << "\n";
    EXPECT_NEAR(found, truth, 0.05 * truth) << "joint " << j + 1;
  }
}

TEST(ElasticControl, TheArmsTrackThePickAndPlaceFourTimesBetterWithTheFittedModel) {
  const testsupport::ScratchDirectory scratch{"delta_hil_elastic"};
  const std::string dir = scratch.path();
  hil::Child emu = hil::start_emulator({"--robot", kSource + "/tests/data/robots/elastic.json"});
  {
    hil::Child rec = hil::start_recorder(dir + "/path1.csv");
    // one period of path1's 0.2 Hz
    hil::Child fw = hil::start_path1_firmware({"--set", "arm_encoders=true"}, 1);
    ASSERT_EQ(fw.wait(300s).value_or(-1), 0) << fw.err();
    ASSERT_EQ(rec.wait(60s).value_or(-1), 0) << rec.err();
  }
  expect_stiffness_from_arm_encoders(dir);
  hil::Child fit =
      hil::Child::spawn({kBin + "/host_id", "fit", dir + "/path1.csv", "--gearbox-stiffness",
                         "3000", "--out", dir + "/fit.json", "--quiet"});
  ASSERT_EQ(fit.wait(300s).value_or(-1), 0) << fit.err();
  pick_and_place({});
  const std::string said = pick_and_place({"--set", "feed_forward.model=" + dir + "/fit.json"});
  EXPECT_NE(said.find("deflection compensation on (gearbox stiffness 3000, 3000, 3000 N m/rad)"),
            std::string::npos)
      << said;
  EXPECT_EQ(emu.terminate(30s).value_or(-1), 0) << emu.err();
  const std::vector<double> worst = worst_arm_tracking(emu.out());
  ASSERT_EQ(worst.size(), 3u) << "path1, nominal, model: " << emu.out();
  std::cout << "pick-and-place on the elastic robot, worst joint's RMS arm tracking: nominal "
            << worst[1] << " rad, identified model with compensation " << worst[2] << " rad ("
            << worst[1] / worst[2] << "x)\n";
  EXPECT_GE(worst[1], 4.0 * worst[2]);
}

}  // namespace
