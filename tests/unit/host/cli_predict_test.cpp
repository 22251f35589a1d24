// host_id predict through the command line: the model's torque at every
// sample a fit uses, and the state filter's cut-off per log.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_fixture.hpp"
#include "delta/read_file.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {
namespace {

using cli_test::CliTest;

// predict: the model's torque at every sample a fit uses, the states it
// used, the measured torque, the log's metadata; its RMSE, computed here
// from the columns, equals what predict and validate report (validate's
// from moments accumulated while preprocessing, a different computation).
TEST_F(CliTest, PredictWritesTheModelTorqueOfEverySampleTheFitUses) {
  simulate("a.csv", {"--torque-noise", "0.01", "--seed", "1"});
  simulate("b.csv", {"--torque-noise", "0.01", "--seed", "2", "--trajectory", "pick-and-place"});
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--out", path("r.json"), "--quiet"}), 0)
      << err_.str();
  ASSERT_EQ(run({"predict", path("r.json"), path("b.csv"), "-o", path("pred.csv"), "--json"}), 0)
      << err_.str();
  const auto summary = nlohmann::json::parse(out_.str());
  const DeltaLog in = read_delta_log(path("b.csv"));
  const DeltaLog pred = read_delta_log(path("pred.csv"));
  // 4 s at 1 kHz, 150 samples trimmed at each end (20 Hz cut-off).
  ASSERT_EQ(pred.size(), in.size() - 300);
  EXPECT_EQ(summary["samples"].get<std::size_t>(), pred.size());
  EXPECT_EQ(summary["samples_left_out"].get<std::size_t>(), 300u);
  EXPECT_TRUE(pred.has_qd && pred.has_qdd);
  EXPECT_EQ(pred.metadata_value("plant"), std::optional<std::string>("lumped"));
  EXPECT_EQ(pred.metadata_value("predicted_by"), std::optional<std::string>("host_id predict"));
  EXPECT_EQ(pred.metadata_value("model"), std::optional<std::string>("delta"));
  ASSERT_EQ(pred.extra_columns.size(), 3u);
  std::array<double, 3> sum_sq{};
  for (std::size_t k = 0; k < pred.size(); ++k) {
    EXPECT_EQ(pred.t[k], in.t[k + 150]);
    for (unsigned j = 0; j < 3; ++j) {
      EXPECT_EQ(pred.tau[j][k], in.tau[j][k + 150]);  // measured, not filtered
      sum_sq[j] += std::pow(pred.tau[j][k] - pred.extra_columns[j].second[k], 2);
    }
  }
  EXPECT_EQ(pred.extra_columns[0].first, "tau_model1");
  ASSERT_EQ(run({"validate", path("r.json"), path("b.csv"), "--json"}), 0) << err_.str();
  const auto v = nlohmann::json::parse(out_.str());
  for (unsigned j = 0; j < 3; ++j) {
    const double rmse = std::sqrt(sum_sq[j] / static_cast<double>(pred.size()));
    EXPECT_NEAR(summary["rmse_measured_Nm"][j].get<double>(), rmse, 1e-12 * rmse);
    EXPECT_NEAR(v["validation"][0]["rmse_measured_Nm"][j].get<double>(), rmse, 1e-8 * rmse);
    // The noise is in the measured RMSE, mostly filtered out of the other.
    EXPECT_LT(v["validation"][0]["rmse_filtered_Nm"][j].get<double>(), 0.5 * rmse);
  }
}

// With the log's own qd and qdd nothing is filtered or trimmed: the states
// are the log's, and an exact fit predicts the torque to rounding.
TEST_F(CliTest, PredictUsesTheLogsDerivativesAsTheyAre) {
  simulate("a.csv", {"--with-derivatives"});
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--out", path("r.json"), "--quiet"}), 0)
      << err_.str();
  ASSERT_EQ(run({"predict", path("r.json"), path("a.csv"), "-o", path("pred.csv")}), 0)
      << err_.str();
  EXPECT_NE(out_.str().find("qd and qdd from the log's columns"), std::string::npos) << out_.str();
  const DeltaLog in = read_delta_log(path("a.csv"));
  const DeltaLog pred = read_delta_log(path("pred.csv"));
  ASSERT_EQ(pred.size(), in.size());
  for (std::size_t k = 0; k < pred.size(); k += 97) {
    for (unsigned j = 0; j < 3; ++j) {
      EXPECT_EQ(pred.q[j][k], in.q[j][k]);
      EXPECT_EQ(pred.qd[j][k], in.qd[j][k]);
      EXPECT_EQ(pred.qdd[j][k], in.qdd[j][k]);
      EXPECT_NEAR(pred.extra_columns[j].second[k], in.tau[j][k], 1e-9);
    }
  }
}

// q's cut-off: chosen from each log's content by default and saved as
// "auto", so that predict and validate choose it from their own logs; a
// number where set; a result saved before it had its own key filtered q
// at cutoff_hz, and predict does so still.
TEST_F(CliTest, TheStateCutoffIsChosenPerLogUnlessSet) {
  simulate("a.csv", {"--torque-noise", "0.01", "--encoder-bits", "17"});
  simulate("b.csv", {"--encoder-bits", "17", "--trajectory", "pick-and-place"});
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--out", path("r.json"), "--quiet"}), 0)
      << err_.str();
  auto j = nlohmann::json::parse(delta::read_whole_file(path("r.json")));
  EXPECT_EQ(j["preprocessing"]["state_cutoff_hz"], "auto");
  EXPECT_GE(j["preprocessing"]["state_cutoff_hz_used"].get<double>(), 20.0);
  ASSERT_EQ(run({"predict", path("r.json"), path("b.csv"), "-o", path("p.csv")}), 0) << err_.str();
  EXPECT_NE(out_.str().find("chosen from the log's spectrum; noise floor"), std::string::npos)
      << out_.str();

  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--state-cutoff-hz", "35", "--out",
                 path("r35.json"), "--quiet"}),
            0)
      << err_.str();
  j = nlohmann::json::parse(delta::read_whole_file(path("r35.json")));
  EXPECT_EQ(j["preprocessing"]["state_cutoff_hz"], 35.0);
  ASSERT_EQ(run({"predict", path("r35.json"), path("b.csv"), "-o", path("p.csv")}), 0);
  EXPECT_NE(out_.str().find("q low-pass filtered at 35 Hz (as set"), std::string::npos)
      << out_.str();

  j["preprocessing"].erase("state_cutoff_hz");
  std::ofstream(path("old.json")) << j.dump();
  ASSERT_EQ(run({"predict", path("old.json"), path("b.csv"), "-o", path("p.csv")}), 0);
  EXPECT_NE(out_.str().find("q low-pass filtered at 20 Hz (as set"), std::string::npos)
      << out_.str();
  j["preprocessing"]["state_cutoff_hz"] = "fast";
  std::ofstream(path("bad.json")) << j.dump();
  EXPECT_EQ(run({"predict", path("bad.json"), path("b.csv"), "-o", path("p.csv")}), 1);
  EXPECT_NE(err_.str().find("preprocessing.state_cutoff_hz is 'fast', not auto or a number"),
            std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--state-cutoff-hz", "fast"}), 2);
}

TEST_F(CliTest, PredictNamesWhatIsWrongAndWritesNothing) {
  simulate("a.csv");
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--out", path("r.json"), "--quiet"}), 0);
  EXPECT_EQ(run({"predict", path("none.json"), path("a.csv"), "-o", path("p.csv")}), 1);
  EXPECT_NE(err_.str().find(path("none.json") + ": cannot open"), std::string::npos) << err_.str();
  std::ofstream(path("bad.csv")) << "# format = delta-log/1\n# upper_arm_length_m = 0.2\n";
  EXPECT_EQ(run({"predict", path("r.json"), path("bad.csv"), "-o", path("p.csv")}), 1);
  EXPECT_NE(err_.str().find(path("bad.csv") + ":"), std::string::npos) << err_.str();
  EXPECT_EQ(run({"predict", path("r.json"), path("a.csv")}), 2);  // -o is required
  EXPECT_FALSE(exists("p.csv"));
}

// -o onto an input is refused before any work, and the input stays as it
// was: predict's log and result, fit's log (also as --plot).
TEST_F(CliTest, AnOutputOntoAnInputIsRefused) {
  simulate("a.csv");
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--out", path("r.json"), "--quiet"}), 0);
  const std::string log = delta::read_whole_file(path("a.csv"));
  const std::string result = delta::read_whole_file(path("r.json"));
  EXPECT_EQ(run({"predict", path("r.json"), path("a.csv"), "-o", path("a.csv")}), 2);
  EXPECT_NE(err_.str().find("-o " + path("a.csv") + " is the input " + path("a.csv") +
                            ": it would be overwritten"),
            std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"predict", path("r.json"), path("a.csv"), "-o", path("r.json")}), 2);
  EXPECT_EQ(run({"fit", path("a.csv"), "--method", "ls", "-o", path("a.csv")}), 2);
  EXPECT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--validate", path("r.json"), "-o",
                 path("r.json")}),
            2);
  EXPECT_EQ(delta::read_whole_file(path("a.csv")), log);
  EXPECT_EQ(delta::read_whole_file(path("r.json")), result);
}

// A result an older host_id saved without the geometry: predict goes on,
// with a warning that the log's robot cannot be checked.
TEST_F(CliTest, AResultWithoutTheGeometryIsSaidToBeUnchecked) {
  simulate("a.csv");
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--out", path("r.json"), "--quiet"}), 0);
  auto j = nlohmann::json::parse(delta::read_whole_file(path("r.json")));
  j.erase("geometry");
  std::ofstream(path("old.json")) << j.dump();
  ASSERT_EQ(run({"predict", path("old.json"), path("a.csv"), "-o", path("p.csv")}), 0)
      << err_.str();
  EXPECT_NE(err_.str().find(path("old.json") +
                            ": warning: the result has no geometry (saved by an older host_id)"),
            std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find("cannot be checked"), std::string::npos);
}

}  // namespace
}  // namespace host_id
