// host_id design and trajectory files through the command line: a
// designed file that simulate runs, one outside the limits, a file's
// errors, and what design keeps or refuses.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <functional>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "cli_fixture.hpp"
#include "delta/input_error.hpp"
#include "delta/read_file.hpp"
#include "delta/trajectory_file.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {
namespace {

using cli_test::CliTest;

// design writes a trajectory file that simulate runs from rest to rest;
// the file reads back to the same trajectory.
TEST_F(CliTest, DesignWritesATrajectoryFileThatSimulateRuns) {
  ASSERT_EQ(run({"design", "-o", path("t.json"), "--iterations", "40", "--json"}), 0) << err_.str();
  const auto summary = nlohmann::json::parse(out_.str());
  EXPECT_GT(summary["preset"]["condition_number_scaled"].get<double>(),
            summary["designed"]["condition_number_scaled"].get<double>());
  const delta::BlendedFourierTrajectory t = delta::read_trajectory_file(path("t.json"));
  EXPECT_EQ(t.fourier.a_rad_s[0].size(), 5u);
  EXPECT_DOUBLE_EQ(t.duration_s(), 12.0);
  ASSERT_EQ(run({"simulate", "--trajectory-file", path("t.json"), "-o", path("d.csv")}), 0)
      << err_.str();
  const DeltaLog log = read_delta_log(path("d.csv"));
  ASSERT_EQ(log.size(), 12001u);  // 12 s at 1 kHz, both ends
  for (unsigned j = 0; j < 3; ++j) {
    // At rest at q0 at both ends.
    EXPECT_NEAR(log.q[j].front(), t.fourier.q0_rad[j], 1e-12);
    EXPECT_NEAR(log.q[j].back(), t.fourier.q0_rad[j], 1e-12);
  }
  EXPECT_EQ(log.metadata_value("trajectory"), std::optional<std::string>(path("t.json")));
  EXPECT_EQ(run({"simulate", "--trajectory-file", path("t.json"), "--trajectory", "fourier", "-o",
                 path("e.csv")}),
            2);
}

// A trajectory file that breaks the controller's limits (here a designed
// one run 4 times faster: 16 times its accelerations) is refused by
// simulate, naming the limit, the time and the joint; --ignore-limits
// simulates it with a warning.
TEST_F(CliTest, SimulateRefusesATrajectoryFileOutsideTheLimits) {
  ASSERT_EQ(run({"design", "-o", path("t.json"), "--iterations", "5"}), 0) << err_.str();
  auto j = nlohmann::json::parse(delta::read_whole_file(path("t.json")));
  j["base_frequency_hz"] = 4.0 * j["base_frequency_hz"].get<double>();  // 16 x the accelerations
  std::ofstream(path("wide.json")) << j.dump();
  EXPECT_EQ(run({"simulate", "--trajectory-file", path("wide.json"), "-o", path("w.csv")}), 1);
  EXPECT_NE(
      err_.str().find(path("wide.json") + ": the trajectory breaks the controller's limits ("),
      std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find("give --ignore-limits to simulate it anyway"), std::string::npos);
  EXPECT_FALSE(exists("w.csv"));
  EXPECT_EQ(run({"simulate", "--trajectory-file", path("wide.json"), "--ignore-limits", "-o",
                 path("w.csv")}),
            0)
      << err_.str();
  EXPECT_NE(err_.str().find("host_id simulate: warning: "), std::string::npos) << err_.str();
  EXPECT_TRUE(exists("w.csv"));
}

TEST_F(CliTest, TrajectoryFileErrorsNameTheFileAndTheKey) {
  ASSERT_EQ(run({"design", "-o", path("t.json"), "--iterations", "5"}), 0) << err_.str();
  auto j = nlohmann::json::parse(delta::read_whole_file(path("t.json")));
  const auto error_with = [&](const std::function<void(nlohmann::json&)>& change) {
    auto k = j;
    change(k);
    std::ofstream(path("bad.json")) << k.dump();
    try {
      delta::read_trajectory_file(path("bad.json"));
    } catch (const delta::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const std::string f = path("bad.json") + ": ";
  EXPECT_EQ(error_with([](auto& k) { k["format"] = "x"; }),
            f + "format: must be \"delta-trajectory/1\" (got \"x\")");
  EXPECT_EQ(error_with([](auto& k) { k["speed"] = 1; }), f + "speed: unknown key");
  EXPECT_EQ(error_with([](auto& k) { k.erase("blend_s"); }), f + "blend_s: missing");
  EXPECT_EQ(error_with([](auto& k) { k["periods"] = 1.5; }), f + "periods: must be a whole number");
  EXPECT_EQ(error_with([](auto& k) { k["sin_amplitude_rad"][1][2] = "a"; }),
            f + "sin_amplitude_rad[1][2]: must be a finite number");
  EXPECT_EQ(error_with([](auto& k) { k["cos_amplitude_rad"][2].push_back(0.1); }),
            f + "cos_amplitude_rad: every joint needs the same number of harmonics in both arrays");
  EXPECT_EQ(error_with([](auto& k) {
              for (std::size_t r = 0; r < 3; ++r) {
                for (int n = 0; n < 2; ++n) {
                  k["sin_amplitude_rad"][r].push_back(0.0);
                  k["cos_amplitude_rad"][r].push_back(0.0);
                }
              }
            }),
            f + "sin_amplitude_rad: must have 1 to 6 harmonics per joint (got 7)");
  EXPECT_EQ(run({"simulate", "--trajectory-file", path("bad.json"), "-o", path("x.csv")}), 1);
  EXPECT_FALSE(exists("x.csv"));
}

// A joint range whose lower end is positive: the search's margin shrinks
// the range about its middle (scaling the ends widened it, and the best
// candidate then broke the real limit), and the design keeps it.
TEST_F(CliTest, DesignKeepsAJointRangeAboveZero) {
  ASSERT_EQ(run({"design", "-o", path("t.json"), "--min-rad", "0.1", "--iterations", "100"}), 0)
      << err_.str();
  ASSERT_EQ(run({"simulate", "--trajectory-file", path("t.json"), "--with-derivatives", "-o",
                 path("d.csv")}),
            0)
      << err_.str();
  const DeltaLog log = read_delta_log(path("d.csv"));
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_GE(*std::min_element(log.q[j].begin(), log.q[j].end()), 0.1) << "joint " << j + 1;
  }
}

// The robot description's limits (its "limits") are the controller's
// (robot = FILE): design designs within them where no option says
// otherwise and records them, and simulate checks its built-in paths
// against them (a path without them is not checked, as before).
TEST_F(CliTest, DesignAndSimulateTakeTheRobotDescriptionsLimits) {
  auto robot = nlohmann::json::parse(delta::read_whole_file("docs/examples/robot.json"));
  robot["limits"] = {{"min_rad", -0.4}, {"max_torque_Nm", 40.0}};
  std::ofstream(path("robot.json")) << robot.dump();
  ASSERT_EQ(run({"design", "-o", path("t.json"), "--robot", path("robot.json"), "--max-rad", "1.3",
                 "--iterations", "20", "--json"}),
            0)
      << err_.str();
  const auto limits = nlohmann::json::parse(out_.str())["limits"];
  EXPECT_EQ(limits["min_rad"].get<double>(), -0.4);            // the file's
  EXPECT_EQ(limits["max_torque_Nm"].get<double>(), 40.0);      // the file's
  EXPECT_EQ(limits["max_rad"].get<double>(), 1.3);             // the option's
  EXPECT_EQ(limits["max_velocity_rad_s"].get<double>(), 6.0);  // the controller's default
  ASSERT_EQ(run({"simulate", "--trajectory-file", path("t.json"), "--with-derivatives", "-o",
                 path("d.csv")}),
            0)
      << err_.str();
  const DeltaLog log = read_delta_log(path("d.csv"));
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_GE(*std::min_element(log.q[j].begin(), log.q[j].end()), -0.4) << "joint " << j + 1;
  }
  // The built-in Fourier path at 0.8 rad leaves [-0.4, 1.4]: refused with
  // the file's limits, simulated without them.
  EXPECT_EQ(
      run({"simulate", "--robot", path("robot.json"), "--amplitude", "0.8", "-o", path("f.csv")}),
      1);
  EXPECT_NE(err_.str().find("the fourier path: the trajectory breaks the controller's limits "
                            "(joint range at t = "),
            std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find(path("robot.json") + "'s limits)"), std::string::npos) << err_.str();
  EXPECT_FALSE(exists("f.csv"));
  EXPECT_EQ(run({"simulate", "--amplitude", "0.8", "-o", path("f.csv")}), 0) << err_.str();
}

// design --criterion calibration: a run for fit --calibrate-torque that
// raises the weakest joint's payload torque, so that what the model does
// not hold weighs less in the scales. On a robot with the whole drive
// train (tests/data/robots/calibration.json: arms 0.7 kg 3 % apart, cogging
// 0.03 N m, gearboxes 2700-3400 N m/rad, torque constants +6/-5/+10 %, a
// 0.5 ms current filter, 5 % load friction), the same 12 s design run empty
// and with 0.5 kg (1.5 % noise, 17-bit encoders) calibrates every joint
// within 1 %, as the condition-number design does now that the cogging is
// found and taken in; with the cogging left out (--cogging-periods 0, as
// an effect without a term), the calibration run still does, and better.
TEST_F(CliTest, ACalibrationRunFromDesignCalibratesTheTorqueScaleWithinOnePerCent) {
  const std::string robot = "tests/data/robots/calibration.json";
  auto loaded = nlohmann::json::parse(delta::read_whole_file(robot));
  loaded["payload"] = {{"mass_kg", 0.5}, {"com_m", {0.0, 0.0, -0.02}}};
  std::ofstream(path("loaded.json")) << loaded.dump();
  const std::array<double, 3> truth{1 / 1.06, 1 / 0.95, 1 / 1.10};  // logged per true torque
  std::map<std::string, double> worst;
  std::map<std::string, double> weakest_payload;
  for (const std::string criterion : {"cond", "calibration"}) {
    const std::string traj = path(criterion + ".json");
    ASSERT_EQ(run({"design", "-o", traj, "--robot", robot, "--criterion", criterion, "--json"}), 0)
        << err_.str();
    const auto rms = nlohmann::json::parse(out_.str())["designed"]["payload_torque_rms_Nm_per_kg"];
    weakest_payload[criterion] =
        std::min({rms[0].get<double>(), rms[1].get<double>(), rms[2].get<double>()});
    for (const auto& [log, file, seed] :
         {std::tuple{"e.csv", robot, "1"}, std::tuple{"l.csv", path("loaded.json"), "2"}}) {
      ASSERT_EQ(
          run({"simulate", "--plant", "mujoco", "--robot", file, "--trajectory-file", traj,
               "--torque-noise", "0.015", "--encoder-bits", "17", "--seed", seed, "-o", path(log)}),
          0)
          << err_.str();
    }
    // The default calibration (cogging found and taken in), and one that
    // leaves the cogging out, as a model lacks what it has no term for.
    for (const std::string cogging : {"", "0"}) {
      std::vector<std::string> args{"fit",         path("e.csv"),    "--calibrate-torque",
                                    path("l.csv"), "--payload-mass", "0.5",
                                    "--json"};
      if (!cogging.empty()) args.insert(args.end(), {"--cogging-periods", cogging});
      ASSERT_EQ(run(args), 0) << err_.str();
      const auto scale = nlohmann::json::parse(out_.str())["torque_scale"];
      double& w = worst[criterion + cogging];
      for (unsigned j = 0; j < 3; ++j) {
        w = std::max(w, std::abs(scale[j].get<double>() / truth[j] - 1.0));
      }
    }
    std::cout << "[ calib   ] " << criterion << ": weakest payload torque "
              << weakest_payload[criterion] << " N m/kg, worst scale error "
              << 100 * worst[criterion] << " %, " << 100 * worst[criterion + "0"]
              << " % without the cogging term\n";
  }
  EXPECT_GT(weakest_payload["calibration"], 1.15 * weakest_payload["cond"]);
  EXPECT_LT(worst["calibration"], 0.01);
  EXPECT_LT(worst["cond"], 0.01);
  // What the model lacks weighs less on the calibration run.
  EXPECT_LT(worst["calibration0"], 0.01);
  EXPECT_LT(worst["calibration0"], 0.75 * worst["cond0"]);
}

TEST_F(CliTest, DesignRefusesWhatTheControllerCannotRun) {
  EXPECT_EQ(run({"design", "-o", path("t.json"), "--base-hz", "0.2005"}), 2);
  EXPECT_NE(err_.str().find("--base-hz: must be a whole number of mHz"), std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"design", "-o", path("t.json"), "--harmonics", "7"}), 2);
  EXPECT_EQ(run({"design", "-o", path("t.json"), "--min-rad", "1", "--max-rad", "0.5"}), 2);
  EXPECT_NE(err_.str().find("--min-rad (1) must be below --max-rad (0.5)"), std::string::npos)
      << err_.str();
  // 100 periods of 0.1 Hz: 1002 s, more than the controller walks.
  EXPECT_EQ(run({"design", "-o", path("t.json"), "--base-hz", "0.1", "--periods", "100"}), 2);
  EXPECT_NE(err_.str().find("--base-hz 0.1 with --periods 100 and --blend 1 lasts 1002 s; the "
                            "controller runs at most 600 s"),
            std::string::npos)
      << err_.str();
  // No excitation keeps the torque below 0.01 N m against gravity.
  EXPECT_EQ(run({"design", "-o", path("t.json"), "--max-torque", "0.01", "--iterations", "5"}), 1);
  EXPECT_NE(err_.str().find("no excitation within the limits was found: the best breaks the "
                            "torque limit at t = "),
            std::string::npos)
      << err_.str();
  EXPECT_FALSE(exists("t.json"));
}

}  // namespace
}  // namespace host_id
