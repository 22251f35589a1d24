// Cogging through the command line, on the multibody robot with the whole
// drive train (tests/data/robots/calibration.json: arms 0.7 kg 3 % apart,
// cogging 0.03 N m at 6 periods per motor revolution through 10:1 gears,
// so 60 per joint revolution; gearboxes 2700-3400 N m/rad; torque
// constants +6/-5/+10 %; a 0.5 ms current filter; 5 % load friction).
// The default fit of a 20 s Fourier log finds the cogging in its residual
// and takes it in; the pick-and-place it predicts, and the torque scales
// --calibrate-torque finds, are compared with the same commands told that
// there is none (--cogging-periods 0). The model file carries the term to
// predict, and `model load`'s reader says the controller leaves it out.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_fixture.hpp"
#include "delta/identified_model.hpp"
#include "delta/read_file.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {
namespace {

using cli_test::CliTest;

const std::string kRobot = "tests/data/robots/calibration.json";

// The worst joint's RMS error of a prediction file, % of its RMS torque.
double worst_percent(const std::string& prediction) {
  const DeltaLog p = read_delta_log(prediction);
  double worst = 0.0;
  for (unsigned j = 0; j < 3; ++j) {
    const std::string name = "tau_model" + std::to_string(j + 1);
    const auto model = std::find_if(p.extra_columns.begin(), p.extra_columns.end(),
                                    [&](const auto& c) { return c.first == name; });
    EXPECT_NE(model, p.extra_columns.end()) << name;
    if (model == p.extra_columns.end()) return 100.0;
    double e2 = 0.0, t2 = 0.0;
    for (std::size_t k = 0; k < p.size(); ++k) {
      e2 += std::pow(p.tau[j][k] - model->second[k], 2);
      t2 += std::pow(p.tau[j][k], 2);
    }
    worst = std::max(worst, 100.0 * std::sqrt(e2 / t2));
  }
  return worst;
}

class CliCoggingTest : public CliTest {
 protected:
  void SetUp() override {
    auto loaded = nlohmann::json::parse(delta::read_whole_file(kRobot));
    loaded["payload"] = {{"mass_kg", 0.5}, {"com_m", {0.0, 0.0, -0.02}}};
    std::ofstream(path("loaded.json")) << loaded.dump();
    const std::vector<std::string> fourier{"--plant",        "mujoco", "--duration",     "20",
                                           "--base-hz",      "0.4",    "--encoder-bits", "17",
                                           "--torque-noise", "0.015"};
    std::vector<std::string> args{"simulate", "--robot", kRobot, "-o", path("f.csv")};
    args.insert(args.end(), fourier.begin(), fourier.end());
    ASSERT_EQ(run(args), 0) << err_.str();
    args = {"simulate", "--robot", path("loaded.json"), "-o", path("l.csv"), "--seed", "2"};
    args.insert(args.end(), fourier.begin(), fourier.end());
    ASSERT_EQ(run(args), 0) << err_.str();
    ASSERT_EQ(run({"simulate", "--plant", "mujoco", "--robot", kRobot, "--trajectory",
                   "pick-and-place", "--duration", "10", "-o", path("pnp.csv")}),
              0)
        << err_.str();
  }
  void check_the_fit();
  void check_the_calibration();
};

// The default fit finds the cogging and predicts the pick-and-place with it.
void CliCoggingTest::check_the_fit() {
  ASSERT_EQ(run({"fit", path("f.csv"), "--method", "ls", "-o", path("with.json")}), 0)
      << err_.str();
  EXPECT_NE(out_.str().find("the log supports them, fitted"), std::string::npos) << out_.str();
  const auto with = nlohmann::json::parse(delta::read_whole_file(path("with.json")));
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_NEAR(with["model"]["cogging_periods_per_rev"][j].get<double>(), 60.0, 1.5);
    EXPECT_NEAR(with["cogging"]["amplitude_Nm"][j].get<double>(), 0.03, 0.01);
  }
  EXPECT_LT(with["cogging"]["held_out_with_Nm"].get<double>(),
            0.5 * with["cogging"]["held_out_without_Nm"].get<double>());
  ASSERT_EQ(run({"fit", path("f.csv"), "--method", "ls", "--cogging-periods", "0", "-o",
                 path("without.json")}),
            0)
      << err_.str();
  double error[2]{};
  for (const int k : {0, 1}) {
    const std::string result = path(k == 0 ? "with.json" : "without.json");
    ASSERT_EQ(run({"predict", result, path("pnp.csv"), "-o", path("p.csv")}), 0) << err_.str();
    error[k] = worst_percent(path("p.csv"));
  }
  std::cout << "[ cogging ] pick-and-place, worst joint: " << error[0] << " % with the term, "
            << error[1] << " % without\n";
  EXPECT_LT(error[0], 2.0);
  EXPECT_LT(error[0], 0.4 * error[1]);
  // The controller does not run the term: its collision thresholds come
  // from the residual without it, as large as a fit without the term has.
  const auto without = nlohmann::json::parse(delta::read_whole_file(path("without.json")));
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_GT(with["collision_thresholds"]["peak_residual_Nm"][j].get<double>(),
              0.8 * without["collision_thresholds"]["peak_residual_Nm"][j].get<double>())
        << "joint " << j + 1;
  }
  // And says so where it is loaded.
  const delta::IdentifiedModel m = delta::read_identified_model(path("with.json"));
  EXPECT_NEAR(m.cogging_amplitude_Nm[0], 0.03, 0.01);
  EXPECT_NE(delta::left_out_by_controller(m).find("leaves out the fit's cogging (joint 1: "),
            std::string::npos);
  EXPECT_EQ(delta::left_out_by_controller(delta::read_identified_model(path("without.json"))), "");
  // An elastic model is not searched (its angles are the arm's); two
  // values are neither one for all joints nor three.
  ASSERT_EQ(run({"fit", path("f.csv"), "--method", "ls", "--gearbox-stiffness", "3000", "--json"}),
            0)
      << err_.str();
  EXPECT_TRUE(nlohmann::json::parse(out_.str())["cogging"].is_null());
  EXPECT_EQ(run({"fit", path("f.csv"), "--cogging-periods", "60,60"}), 2);
  EXPECT_NE(err_.str().find("--cogging-periods: give one n for all joints or three"),
            std::string::npos)
      << err_.str();
  // A result whose periods are not numbers of 0 to 5000 is refused, naming the key.
  auto bad = with;
  bad["model"]["cogging_periods_per_rev"][1] = -60.0;
  std::ofstream(path("bad.json")) << bad.dump();
  EXPECT_NE(run({"predict", path("bad.json"), path("pnp.csv"), "-o", path("p.csv")}), 0);
  EXPECT_NE(err_.str().find(path("bad.json") + ": model.cogging_periods_per_rev must be three "
                                               "cogging periods per joint revolution"),
            std::string::npos)
      << err_.str();
}

// --calibrate-torque takes it in.
void CliCoggingTest::check_the_calibration() {
  const std::array<double, 3> truth{1 / 1.06, 1 / 0.95, 1 / 1.10};  // logged per true torque
  double worst[2]{};
  for (const int k : {0, 1}) {
    std::vector<std::string> args{"fit",         path("f.csv"),    "--calibrate-torque",
                                  path("l.csv"), "--payload-mass", "0.5",
                                  "--json"};
    if (k == 1) args.insert(args.end(), {"--cogging-periods", "0"});
    ASSERT_EQ(run(args), 0) << err_.str();
    const auto j = nlohmann::json::parse(out_.str());
    for (unsigned i = 0; i < 3; ++i) {
      const double e = std::abs(j["torque_scale"][i].get<double>() / truth[i] - 1.0);
      worst[k] = std::max(worst[k], e);
      if (k == 0) {
        EXPECT_NEAR(j["cogging_periods_per_rev"][i].get<double>(), 60.0, 1.5);
        // The printed standard deviation holds the error at 2 sigma.
        EXPECT_LT(e, 2.0 * j["torque_scale_std"][i].get<double>() / truth[i]) << "joint " << i + 1;
      }
    }
  }
  std::cout << "[ cogging ] torque scale, worst joint: " << 100 * worst[0] << " % with the term, "
            << 100 * worst[1] << " % without\n";
  EXPECT_LT(worst[0], 0.01);
  EXPECT_LT(worst[0], 0.5 * worst[1]);
}

// One test, so that the three logs are simulated once (ctest runs each
// test as a process of its own).
TEST_F(CliCoggingTest, TheDefaultFitAndTheTorqueCalibrationTakeTheCoggingIn) {
  check_the_fit();
  check_the_calibration();
}

}  // namespace
}  // namespace host_id
