// host_id simulate through the command line: its options, the multibody
// robot, --params, --json.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_fixture.hpp"
#include "delta/read_file.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {
namespace {

using cli_test::CliTest;

TEST_F(CliTest, SimulateValidatesItsOptions) {
  EXPECT_EQ(run({"simulate"}), 2);
  EXPECT_NE(err_.str().find("--out is required"), std::string::npos) << err_.str();
  EXPECT_EQ(run({"simulate", "-o", path("s.csv"), "--torque-noise", "1"}), 2);
  EXPECT_NE(err_.str().find("--torque-noise: must be in [0, 1), got '1'"), std::string::npos)
      << err_.str();
  EXPECT_FALSE(exists("s.csv"));
  EXPECT_EQ(run({"simulate", "-o", path("s.csv"), "--trajectory", "pick-and-place", "--segment-s",
                 "0.05"}),
            2);
  EXPECT_NE(err_.str().find("--segment-s: must be in [0.1, 10], got '0.05'"), std::string::npos)
      << err_.str();
  EXPECT_FALSE(exists("s.csv"));
  ASSERT_EQ(run({"simulate", "-o", path("s.csv"), "--trajectory", "pick-and-place", "--duration",
                 "1", "--with-derivatives", "--segment-s", "0.25"}),
            0);
  const std::string text = delta::read_whole_file(path("s.csv"));
  EXPECT_NE(text.find("seq,t,q1,q2,q3,tau1,tau2,tau3,qd1,qd2,qd3,qdd1,qdd2,qdd3\n"),
            std::string::npos);
}

// The multibody robot follows the path under its PD controller: its angles
// stay within a few mrad of the path's (the lumped log has the path's
// exactly), its torques differ from the lumped model's by what the lumped
// model lacks, and its qdd is its own acceleration: the derivative of its qd.
TEST_F(CliTest, SimulateOnTheMultibodyRobotFollowsThePath) {
  simulate("lumped.csv", {"--with-derivatives"});
  simulate("mujoco.csv", {"--plant", "mujoco", "--with-derivatives"});
  const DeltaLog lumped = read_delta_log(path("lumped.csv"));
  const DeltaLog mujoco = read_delta_log(path("mujoco.csv"));
  EXPECT_EQ(mujoco.metadata_value("plant"), "mujoco");
  EXPECT_EQ(lumped.metadata_value("plant"), "lumped");
  ASSERT_EQ(mujoco.size(), lumped.size());
  double worst_q = 0, tau_diff = 0, tau_ss = 0, qdd_err = 0, qdd_ss = 0;
  for (unsigned j = 0; j < 3; ++j) {
    for (std::size_t k = 1; k + 1 < mujoco.size(); ++k) {
      worst_q = std::max(worst_q, std::abs(mujoco.q[j][k] - lumped.q[j][k]));
      tau_diff += std::pow(mujoco.tau[j][k] - lumped.tau[j][k], 2);
      tau_ss += std::pow(lumped.tau[j][k], 2);
      const double from_qd = (mujoco.qd[j][k + 1] - mujoco.qd[j][k - 1]) / 0.002;
      qdd_err += std::pow(mujoco.qdd[j][k] - from_qd, 2);
      qdd_ss += std::pow(from_qd, 2);
    }
  }
  EXPECT_LT(worst_q, 0.001);  // measured 0.19 mrad
  const double tau_rel = std::sqrt(tau_diff / tau_ss);
  EXPECT_GT(tau_rel, 0.005);                     // not the lumped model's torques (measured 1.4 %)
  EXPECT_LT(tau_rel, 0.2);                       // but the same robot's
  EXPECT_LT(std::sqrt(qdd_err / qdd_ss), 0.03);  // measured 1.2 %
}

TEST_F(CliTest, SimulateRefusesWhatTheMultibodyRobotCannotTake) {
  EXPECT_EQ(run({"simulate", "-o", path("s.csv"), "--plant", "mujoco", "--params",
                 "docs/examples/robot.json"}),
            2);
  EXPECT_NE(err_.str().find("--params: only with --plant lumped"), std::string::npos) << err_.str();
  EXPECT_EQ(
      run({"simulate", "-o", path("s.csv"), "--plant", "mujoco", "--robot", path("missing.json")}),
      1);
  EXPECT_NE(err_.str().find(path("missing.json") + ": cannot open"), std::string::npos)
      << err_.str();
  EXPECT_FALSE(exists("s.csv"));
}

// simulate --params takes a lumped fit (its plant's model); a fit of the
// higher-fidelity model is refused by name, and nothing is written.
TEST_F(CliTest, SimulateParamsTakeALumpedFitAndNameAHigherFidelityOne) {
  simulate("a.csv", {"--torque-noise", "0.01"});
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--model", "lumped", "--out",
                 path("lumped.json"), "--quiet"}),
            0)
      << err_.str();
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--out", path("delta.json"), "--quiet"}),
            0)
      << err_.str();
  EXPECT_EQ(run({"simulate", "-o", path("b.csv"), "--params", path("lumped.json")}), 0)
      << err_.str();
  EXPECT_TRUE(exists("b.csv"));
  EXPECT_EQ(run({"simulate", "-o", path("c.csv"), "--params", path("delta.json")}), 1);
  EXPECT_NE(err_.str().find(path("delta.json") + ": parameter 'arm_gravity_cos' is the "
                                                 "higher-fidelity model's"),
            std::string::npos)
      << err_.str();
  EXPECT_FALSE(exists("c.csv"));
}

TEST_F(CliTest, SimulateSummarisesAsJson) {
  ASSERT_EQ(run({"simulate", "-o", path("s.csv"), "--duration", "2", "--json"}), 0) << err_.str();
  const auto j = nlohmann::json::parse(out_.str());
  EXPECT_EQ(j["out"], path("s.csv"));
  EXPECT_EQ(j["samples"], 2001);
  EXPECT_EQ(j["plant"], "lumped");
  EXPECT_EQ(j["trajectory"], "fourier");
  EXPECT_EQ(read_delta_log(path("s.csv")).size(), 2001u);
}

}  // namespace
}  // namespace host_id
