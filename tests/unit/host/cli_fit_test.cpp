// host_id fit through the command line: its result JSON, the model's
// variant (--model auto and the support of a plain fit), another robot's
// log, torque calibration, a payload, --truth, several models.
#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "cli_fixture.hpp"
#include "delta/atomic_file.hpp"
#include "delta/identified_model.hpp"
#include "delta/read_file.hpp"
#include "held_joint_log.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/simulate.hpp"

namespace host_id {
namespace {

using cli_test::CliTest;

// A copy of `from` with its forearm length changed: another robot.
void write_with_forearm(const std::string& from, const std::string& to, const char* forearm) {
  std::ifstream in(from);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string key = "# forearm_length_m = 0.46";
  text.replace(text.find(key), key.size(), std::string("# forearm_length_m = ") + forearm);
  std::ofstream(to) << text;
}

// Parameters fitted on one robot are refused for another, unless asked:
// the result records its geometry, and predict, validate and fit's
// --validate and --truth compare it.
TEST_F(CliTest, AnotherRobotsLogIsRefusedUnlessAllowed) {
  simulate("a.csv");
  write_with_forearm(path("a.csv"), path("other.csv"), "0.5");
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "-o", path("r.json")}), 0) << err_.str();
  const std::string other =
      "is of another robot (upper arm 0.2 m, forearm 0.5 m, base 0.1 m, platform 0.035 m) than ";
  EXPECT_EQ(run({"predict", path("r.json"), path("other.csv"), "-o", path("p.csv")}), 1);
  EXPECT_NE(err_.str().find(path("other.csv") + " " + other + path("r.json") +
                            " was fitted for (upper arm 0.2 m, forearm 0.46 m"),
            std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find("(--allow-other-geometry to go on anyway)"), std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(path("p.csv")));
  EXPECT_EQ(run({"predict", path("r.json"), path("other.csv"), "-o", path("p.csv"),
                 "--allow-other-geometry"}),
            0)
      << err_.str();
  EXPECT_NE(err_.str().find("warning: " + path("other.csv") + " " + other), std::string::npos);
  EXPECT_EQ(run({"validate", path("r.json"), path("other.csv")}), 1);
  EXPECT_NE(err_.str().find(other), std::string::npos) << err_.str();
  EXPECT_EQ(run({"validate", path("r.json"), path("a.csv")}), 0) << err_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--validate", path("other.csv")}), 1);
  EXPECT_NE(err_.str().find(other + "the fitted " + path("a.csv")), std::string::npos)
      << err_.str();
  EXPECT_EQ(
      run({"fit", path("other.csv"), "--method", "ls", "--truth", "docs/examples/robot.json"}), 1);
  EXPECT_NE(err_.str().find(other + "the robot of --truth docs/examples/robot.json"),
            std::string::npos)
      << err_.str();
}

// fit --calibrate-torque: the empty and the loaded robot (the shipped
// robot description, and the same with 0.5 kg on the platform) give each
// joint's torque scale, 1 here; the usage errors name what is missing.
TEST_F(CliTest, CalibratesTheTorqueScaleWithAKnownPayload) {
  auto robot =
      nlohmann::json::parse(delta::read_whole_file(DELTA_SOURCE_DIR "/docs/examples/robot.json"));
  robot["payload"]["mass_kg"] = 0.5;
  delta::write_file_atomically(path("loaded.json"), robot.dump());
  for (const auto& [name, robot_path, seed] :
       {std::tuple{"empty.csv", std::string(DELTA_SOURCE_DIR "/docs/examples/robot.json"), "1"},
        std::tuple{"loaded.csv", path("loaded.json"), "2"}}) {
    ASSERT_EQ(run({"simulate", "-o", path(name), "--duration", "12", "--robot", robot_path,
                   "--seed", seed, "--torque-noise", "0.01"}),
              0)
        << err_.str();
  }
  ASSERT_EQ(run({"fit", path("empty.csv"), "--calibrate-torque", path("loaded.csv"),
                 "--payload-mass", "0.5", "--method", "ls", "--json", "-o", path("scale.json")}),
            0)
      << err_.str();
  const auto j = nlohmann::json::parse(out_.str());
  for (unsigned k = 0; k < 3; ++k) {
    EXPECT_NEAR(j["torque_scale"][k].get<double>(), 1.0, 0.01) << k;
    EXPECT_GT(j["torque_scale_std"][k].get<double>(), 0.0);
  }
  EXPECT_TRUE(j["parameters_true_units"].contains("platform_weight_mass"));
  EXPECT_EQ(nlohmann::json::parse(delta::read_whole_file(path("scale.json"))), j);
  EXPECT_EQ(run({"fit", path("empty.csv"), "--calibrate-torque", path("loaded.csv")}), 2);
  EXPECT_NE(err_.str().find("--calibrate-torque needs --payload-mass KG"), std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", path("empty.csv"), "--payload-mass", "0.5"}), 2);
  EXPECT_NE(err_.str().find("--payload-mass goes with --calibrate-torque"), std::string::npos);
}

TEST_F(CliTest, FitSavesJsonThatValidateReproduces) {
  simulate("p1.csv", {"--torque-noise", "0.01", "--seed", "1"});
  simulate("p2.csv", {"--torque-noise", "0.01", "--seed", "2"});
  ASSERT_EQ(run({"fit", path("p1.csv"), "--validate", path("p2.csv"), "--out", path("r.json"),
                 "--plot", path("p.svg"), "--quiet"}),
            0)
      << err_.str();
  EXPECT_NE(out_.str().find("torque RMSE [N m]"), std::string::npos);
  const auto j = nlohmann::json::parse(delta::read_whole_file(path("r.json")));
  EXPECT_EQ(j["format"], "host_id-result/1");
  EXPECT_EQ(j["parameters"].size(), 12u);
  EXPECT_NEAR(j["parameters"]["platform_weight_mass"].get<double>(), 0.40, 0.02);
  EXPECT_NEAR(j["parameters"]["platform_inertial_mass"].get<double>(), 0.40, 0.02);
  ASSERT_EQ(j["fit"]["rmse_measured_Nm"].size(), 3u);
  ASSERT_EQ(j["fit"]["rmse_filtered_Nm"].size(), 3u);
  ASSERT_EQ(j["validation"].size(), 1u);
  EXPECT_EQ(j["validation"][0]["log"], path("p2.csv"));
  const std::string svg = delta::read_whole_file(path("p.svg"));
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("<polyline"), std::string::npos);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);

  ASSERT_EQ(run({"validate", path("r.json"), path("p2.csv"), "--json"}), 0) << err_.str();
  const auto v = nlohmann::json::parse(out_.str());
  for (std::size_t k = 0; k < 3; ++k) {
    for (const char* key : {"rmse_measured_Nm", "rmse_filtered_Nm"}) {
      EXPECT_DOUBLE_EQ(v["validation"][0][key][k].get<double>(),
                       j["validation"][0][key][k].get<double>());
    }
  }

  // A result saved when 'delta' named the lumped model is refused with the fix.
  auto old = j;
  old["parameters"] = {{"arm_inertia", 7e-3}, {"arm_gravity_moment", 0.44}, {"platform_mass", 0.4}};
  std::ofstream(path("old.json")) << old.dump();
  EXPECT_EQ(run({"validate", path("old.json"), path("p2.csv")}), 1);
  EXPECT_NE(err_.str().find(path("old.json") +
                            ": model.name is 'delta' but the parameters are the lumped model's"),
            std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find("set model.name to 'lumped'"), std::string::npos);
}

// --model auto: the variant the held-out error chooses, in the report and
// the JSON; it decides --per-joint and --offsets itself.
TEST_F(CliTest, ModelAutoSaysWhichVariantItChoseAndWhy) {
  simulate("p1.csv", {"--torque-noise", "0.01"});
  ASSERT_EQ(run({"fit", path("p1.csv"), "--model", "auto", "--method", "ls", "--json"}), 0)
      << err_.str();
  const auto j = nlohmann::json::parse(out_.str());
  ASSERT_TRUE(j.contains("model_support"));
  EXPECT_EQ(j["model_support"]["folds"], 5);
  EXPECT_EQ(j["model_support"]["variants"].size(), 7u);
  EXPECT_EQ(j["model_support"]["chosen"], "shared arms");  // the default robot's arms are equal
  EXPECT_FALSE(j.contains("model_selection")) << "one key for the model's support";
  EXPECT_EQ(j["model"]["name"], "delta");
  EXPECT_EQ(j["model"]["per_joint"], false);
  ASSERT_EQ(run({"fit", path("p1.csv"), "--model", "auto", "--method", "ls"}), 0) << err_.str();
  EXPECT_NE(out_.str().find("<- chosen"), std::string::npos) << out_.str();
  EXPECT_EQ(run({"fit", path("p1.csv"), "--model", "auto", "--per-joint"}), 2);
  EXPECT_NE(err_.str().find("--model auto decides --per-joint, --offsets, --torque-gains and "
                            "--load-friction itself"),
            std::string::npos)
      << err_.str();
}

// Every fit of the delta or lumped model says which variant the log
// supports, judged on its own rows; where another variant's held-out error
// is 10 % or more below the fitted one's, the fit is doubtful and says how
// to fit that variant.
TEST_F(CliTest, APlainFitSaysWhichVariantTheLogSupports) {
  simulate_arms_that_differ("differ.csv");
  simulate("equal.csv", {"--torque-noise", "0.01"});
  ASSERT_EQ(run({"fit", path("differ.csv"), "--model", "lumped", "--method", "ls", "--json"}), 0)
      << err_.str();
  auto j = nlohmann::json::parse(out_.str());
  EXPECT_EQ(j["model_support"]["chosen"], "per-joint arms");
  ASSERT_EQ(j["doubts"].size(), 1u);
  EXPECT_NE(j["doubts"][0].get<std::string>().find("the log supports per-joint arms"),
            std::string::npos);
  EXPECT_NE(j["doubts"][0].get<std::string>().find("fit with --model lumped --per-joint"),
            std::string::npos)
      << j["doubts"][0];
  EXPECT_NE(err_.str().find("warning: the lumped fit is doubtful: the log supports per-joint"),
            std::string::npos)
      << err_.str();
  ASSERT_EQ(run({"fit", path("differ.csv"), "--model", "delta", "--method", "ls"}), 0);
  EXPECT_NE(err_.str().find("fit with --model auto (or --per-joint)"), std::string::npos)
      << err_.str();
  ASSERT_EQ(run({"fit", path("differ.csv"), "--model", "lumped", "--method", "ls", "--per-joint"}),
            0);
  EXPECT_NE(out_.str().find("support   per-joint arms, as fitted"), std::string::npos)
      << out_.str();
  ASSERT_EQ(run({"fit", path("equal.csv"), "--method", "ls", "--json"}), 0) << err_.str();
  j = nlohmann::json::parse(out_.str());
  EXPECT_EQ(j["model_support"]["chosen"], "shared arms");
  EXPECT_TRUE(j["doubts"].empty()) << j["doubts"];
}

// Without --model the variant is the one the log supports (--model auto):
// per-joint arms for arms that differ, fitted from the file again, and no
// doubt left; --per-joint alone names the delta model.
TEST_F(CliTest, TheDefaultModelIsTheVariantTheLogSupports) {
  simulate_arms_that_differ("differ.csv");
  ASSERT_EQ(run({"fit", path("differ.csv"), "--method", "ls", "--json"}), 0) << err_.str();
  auto j = nlohmann::json::parse(out_.str());
  EXPECT_EQ(j["model_support"]["chosen"], "per-joint arms");
  EXPECT_EQ(j["model"]["name"], "delta");
  EXPECT_EQ(j["model"]["per_joint"], true);
  EXPECT_EQ(j["parameters"].size(), 18u);
  EXPECT_TRUE(j["doubts"].empty()) << j["doubts"];
  // Too short to judge: the shared arms, and it says so.
  ASSERT_EQ(run({"simulate", "-o", path("short.csv"), "--duration", "0.39"}), 0) << err_.str();
  ASSERT_EQ(run({"fit", path("short.csv"), "--method", "ls"}), 0) << err_.str();
  EXPECT_NE(err_.str().find("warning: --model auto: 91 samples are too few to judge the model's "
                            "variants on 5 time blocks (at least 100); the shared arms are fitted"),
            std::string::npos)
      << err_.str();
  ASSERT_EQ(run({"fit", path("differ.csv"), "--method", "ls", "--offsets", "--json"}), 0);
  j = nlohmann::json::parse(out_.str());
  EXPECT_FALSE(j.contains("model_selection"));
  EXPECT_EQ(j["model"]["per_joint"], false);
  EXPECT_EQ(j["model"]["offsets"], true);
}

// fit LOADED.csv --base RESULT.json: the payload's mass alone, and with -o
// the base result with the payload added, which predict then uses.
TEST_F(CliTest, APayloadOnABaseFitIsItsMassAndSavesTheLoadedResult) {
  SimulateOptions o;
  o.torque_noise = 0.01;
  o.encoder_bits = 17;
  o.duration_s = 10.0;
  o.seed = 3;
  std::ofstream(path("empty.csv")) << format_delta_log(simulate_log(o));
  o.parameters.platform_mass_kg += 0.3;
  o.seed = 4;
  std::ofstream(path("loaded.csv")) << format_delta_log(simulate_log(o));
  ASSERT_EQ(run({"fit", path("empty.csv"), "--method", "ls", "-o", path("base.json")}), 0)
      << err_.str();
  ASSERT_EQ(run({"fit", path("loaded.csv"), "--base", path("base.json"), "--json", "-o",
                 path("loaded.json")}),
            0)
      << err_.str();
  const auto j = nlohmann::json::parse(out_.str());
  EXPECT_NEAR(j["payload_mass_kg"].get<double>(), 0.3, 0.005);
  EXPECT_GT(j["payload_mass_std_kg"].get<double>(), 0.0);
  const auto base = nlohmann::json::parse(delta::read_whole_file(path("base.json")));
  const auto loaded = nlohmann::json::parse(delta::read_whole_file(path("loaded.json")));
  EXPECT_NEAR(loaded["parameters"]["platform_weight_mass"].get<double>() -
                  base["parameters"]["platform_weight_mass"].get<double>(),
              j["payload_mass_kg"].get<double>(), 1e-12);
  EXPECT_EQ(loaded["parameters"]["arm_inertia"], base["parameters"]["arm_inertia"]);
  ASSERT_EQ(
      run({"predict", path("loaded.json"), path("loaded.csv"), "-o", path("p.csv"), "--json"}), 0)
      << err_.str();
  const auto pred = nlohmann::json::parse(out_.str());
  EXPECT_LT(pred["rmse_measured_Nm"][0].get<double>(), 0.05);
  EXPECT_EQ(run({"fit", path("loaded.csv"), "--base", path("base.json"), "--model", "lumped"}), 2);
}

TEST_F(CliTest, JsonOutputHasTheDocumentedKeys) {
  simulate("p1.csv", {"--torque-noise", "0.01"});
  ASSERT_EQ(run({"fit", path("p1.csv"), "--json", "--method", "ls", "--model", "paper14"}), 0)
      << err_.str();
  const auto j = nlohmann::json::parse(out_.str());
  EXPECT_EQ(j["method"], "ls");
  EXPECT_EQ(j["model"]["name"], "paper14");
  EXPECT_EQ(j["parameters"].size(), 14u);
  EXPECT_TRUE(j["parameters"].contains("beta1"));
  EXPECT_TRUE(j["pso"].is_null());
  EXPECT_TRUE(j["validation"].is_array());
  EXPECT_GT(j["least_squares"]["condition_number"].get<double>(), 1.0);
  EXPECT_TRUE(j["doubts"].is_array());
  EXPECT_EQ(j["correlation"]["parameters"].size(), 14u);
  EXPECT_EQ(j["correlation"]["matrix"].size(), 14u);
  EXPECT_NEAR(j["correlation"]["matrix"][3][3].get<double>(), 1.0, 1e-12);
  // 4 s at 1 kHz filtered at 20 Hz: residuals correlated over 2 * 1000 / 20 samples.
  EXPECT_EQ(j["least_squares"]["std_dev_correlation_lags"], 100);
  // paper14 fits every sample, as the paper does.
  EXPECT_EQ(j["preprocessing"]["min_speed_rad_s"], 0.0);
  const std::size_t samples = j["fit"]["samples"];
  EXPECT_EQ(j["preprocessing"]["equations_used"], nlohmann::json({samples, samples, samples}));
}

TEST_F(CliTest, MinSpeedLeavesOutSlowEquationsAndSaysHowMany) {
  simulate("p1.csv", {"--torque-noise", "0.01"});
  ASSERT_EQ(run({"fit", path("p1.csv"), "--method", "ls", "--min-speed", "0.3"}), 0) << err_.str();
  EXPECT_NE(out_.str().find("(left out: |qd| < 0.3 rad/s)"), std::string::npos) << out_.str();
  ASSERT_EQ(run({"fit", path("p1.csv"), "--method", "ls", "--json"}), 0) << err_.str();
  const auto j = nlohmann::json::parse(out_.str());
  EXPECT_EQ(j["preprocessing"]["min_speed_rad_s"], 0.05);
  const std::size_t samples = j["fit"]["samples"];
  for (const auto& used : j["preprocessing"]["equations_used"]) {
    EXPECT_LT(used.get<std::size_t>(), samples);
    EXPECT_GT(used.get<std::size_t>(), samples / 2);
  }
  EXPECT_EQ(run({"fit", path("p1.csv"), "--min-speed", "-1"}), 2);
  EXPECT_NE(err_.str().find("host_id fit: error: --min-speed: must be >= 0, got '-1'"),
            std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", path("p1.csv"), "--method", "ls", "--min-speed", "100"}), 1);
  EXPECT_NE(err_.str().find("p1.csv: joint 1 is never faster than the minimum speed of 100"),
            std::string::npos)
      << err_.str();
}

// --truth ROBOT.json: each estimate beside the truth derived from the
// robot, in the text and the JSON; paper14's coefficients have none.
TEST_F(CliTest, FitPrintsTheTruthOfARobotDescriptionBesideEachEstimate) {
  simulate("a.csv", {"--torque-noise", "0.01"});
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--truth", "docs/examples/robot.json",
                 "--out", path("r.json")}),
            0)
      << err_.str();
  EXPECT_NE(out_.str().find("rel std          truth     error   unit"), std::string::npos)
      << out_.str();
  // The higher-fidelity model's arm inertia, and the lumped model's.
  EXPECT_NE(out_.str().find("0.00666849"), std::string::npos) << out_.str();
  const auto j = nlohmann::json::parse(delta::read_whole_file(path("r.json")));
  bool found = false;
  for (const auto& d : j.at("parameter_details")) {
    if (d.at("name") == "platform_inertial_mass") {
      EXPECT_NEAR(d.at("truth").get<double>(), 0.36, 1e-4);
      found = true;
    }
  }
  EXPECT_TRUE(found);
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--model", "lumped", "--truth",
                 "docs/examples/robot.json"}),
            0);
  EXPECT_NE(out_.str().find("0.0072017"), std::string::npos) << out_.str();
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls", "--model", "paper14", "--truth",
                 "docs/examples/robot.json"}),
            0);
  EXPECT_EQ(out_.str().find("truth"), std::string::npos) << out_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--truth", path("none.json")}), 1);
  EXPECT_NE(err_.str().find(path("none.json") + ": cannot open"), std::string::npos) << err_.str();
}

// --model given more than once: each model fitted on the same logs, the
// report's Table 2 over all of them, the first model saved (with the others
// under other_models) and plotted, with the residual against velocity.
TEST_F(CliTest, SeveralModelsShareOneTable2) {
  simulate("a.csv", {"--torque-noise", "0.01"});
  simulate("b.csv", {"--torque-noise", "0.01", "--seed", "2", "--trajectory", "pick-and-place"});
  ASSERT_EQ(run({"fit", path("a.csv"), "--validate", path("b.csv"), "--method", "ls", "--model",
                 "delta", "--model", "lumped", "--model", "paper14", "--offsets", "--out",
                 path("r.json"), "--plot", path("p.svg")}),
            0)
      << err_.str();
  const std::string text = out_.str();
  const auto table = text.find("Table 2: torque RMSE per joint [N m]");
  ASSERT_NE(table, std::string::npos) << text;
  for (const char* model : {"delta", "lumped", "paper14"}) {
    for (const char* row : {" fit      a.csv", " validate b.csv"}) {
      // Once against the measured torque, once against the filtered.
      const std::string line = std::string("  ") + model;
      std::size_t at =
          text.find(line + std::string(8 - std::string(model).size(), ' ') + row, table);
      ASSERT_NE(at, std::string::npos) << model << row << "\n" << text;
      at = text.find(line + std::string(8 - std::string(model).size(), ' ') + row, at + 1);
      EXPECT_NE(at, std::string::npos) << model << row;
    }
  }
  // --offsets applies to the physical models; paper14 is fitted without.
  EXPECT_NE(text.find("model     paper14 (the paper's regressor"), std::string::npos);
  const auto j = nlohmann::json::parse(delta::read_whole_file(path("r.json")));
  EXPECT_EQ(j["model"]["name"], "delta");
  EXPECT_TRUE(j["model"]["offsets"].get<bool>());
  ASSERT_EQ(j["other_models"].size(), 2u);
  EXPECT_EQ(j["other_models"][0]["model"]["name"], "lumped");
  EXPECT_EQ(j["other_models"][1]["model"]["name"], "paper14");
  EXPECT_FALSE(j["other_models"][1]["model"]["offsets"].get<bool>());
  const std::string svg = delta::read_whole_file(path("p.svg"));
  EXPECT_NE(svg.find("residual against joint velocity"), std::string::npos);
  EXPECT_NE(svg.find("joint 3: residual"), std::string::npos);
  // validate reads the primary model's result.
  ASSERT_EQ(run({"validate", path("r.json"), path("b.csv")}), 0) << err_.str();
  EXPECT_NE(out_.str().find("(model delta)"), std::string::npos);
}

// A log that cannot separate every parameter: the report names what is not
// identifiable and which combinations the values stand for; the saved
// result has null for the former, and validate and predict use it.
TEST_F(CliTest, UnidentifiableParametersAreNamedNotPrinted) {
  const DeltaLog log =
      testlogs::log_with_joint3_held(4.0, 0.35, delta::default_lumped_parameters());
  delta::write_file_atomically(path("held.csv"), format_delta_log(log));
  ASSERT_EQ(run({"fit", path("held.csv"), "--model", "lumped", "--per-joint", "--offsets",
                 "--min-speed", "0", "--method", "ls", "--out", path("r.json")}),
            0)
      << err_.str();
  const std::string text = out_.str();
  const auto line = text.find("  arm_inertia_3 ");
  ASSERT_NE(line, std::string::npos) << text;
  EXPECT_EQ(text.substr(line, text.find('\n', line) - line).find("not identifiable on this log") !=
                std::string::npos,
            true)
      << text;
  EXPECT_NE(text.find("(estimates "), std::string::npos) << text;
  EXPECT_NE(text.find("does not excite 'arm_inertia_3' 'viscous_friction_3' "
                      "'coulomb_friction_3' at all"),
            std::string::npos)
      << text;
  const auto j = nlohmann::json::parse(delta::read_whole_file(path("r.json")));
  EXPECT_TRUE(j["parameters"]["arm_inertia_3"].is_null());
  EXPECT_TRUE(j["parameters"]["arm_inertia_1"].is_number());
  ASSERT_EQ(run({"validate", path("r.json"), path("held.csv"), "--json"}), 0) << err_.str();
  const auto v = nlohmann::json::parse(out_.str());
  for (unsigned k = 0; k < 3; ++k) {
    EXPECT_LT(v["validation"][0]["rmse_filtered_Nm"][k].get<double>(), 1e-9);
    // From moments: a floor near 1e-7 of the RMS torque.
    EXPECT_LT(v["validation"][0]["rmse_measured_Nm"][k].get<double>(), 1e-6);
  }
}

}  // namespace
}  // namespace host_id

namespace host_id {
namespace {

// The drive train's terms, asked for by name: in the report's model line,
// the saved result and the JSON, and read back for the controller.
TEST_F(CliTest, TheDriveTrainsTermsAreFittedSavedAndReadBackForTheController) {
  simulate("p1.csv", {"--torque-noise", "0.01"});
  ASSERT_EQ(run({"fit", path("p1.csv"), "--torque-gains", "--load-friction", "--method", "ls", "-o",
                 path("r.json")}),
            0)
      << err_.str();
  EXPECT_NE(out_.str().find("load friction, torque gains"), std::string::npos) << out_.str();
  for (const char* name : {"load_friction_1", "load_friction_3", "torque_gain_gap_2"}) {
    EXPECT_NE(out_.str().find(name), std::string::npos) << name;
  }
  const auto saved = nlohmann::json::parse(delta::read_whole_file(path("r.json")));
  EXPECT_EQ(saved["model"]["torque_gains"], true);
  EXPECT_EQ(saved["model"]["load_friction"], true);
  const delta::IdentifiedModel m = delta::read_identified_model(path("r.json"));
  EXPECT_EQ(m.drive_train.torque_gain_gap[0], 0.0);
  EXPECT_EQ(m.drive_train.torque_gain_gap[1], saved["parameters"]["torque_gain_gap_2"]);
  EXPECT_EQ(m.drive_train.load_friction[2], saved["parameters"]["load_friction_3"]);
  ASSERT_EQ(run({"predict", path("r.json"), path("p1.csv"), "-o", path("pred.csv")}), 0)
      << err_.str();
  EXPECT_EQ(run({"fit", path("p1.csv"), "--torque-gains", "--model", "paper14"}), 1);
  EXPECT_NE(err_.str().find("apply to --model delta and lumped only"), std::string::npos)
      << err_.str();
}

}  // namespace
}  // namespace host_id

namespace host_id {
namespace {

// The calibration on a multibody robot whose drive train biases it: arms
// 3 % apart, torque constants 6 %, -5 %, +10 % off and gear friction of 5 %
// of the gear's torque (no cogging). Per-joint arms and load friction in
// the calibration's model bring every joint's scale within 0.5 % of
// 1 / ratio (shared arms and no load friction: 1.9 % off).
TEST_F(CliTest, TheTorqueScaleHoldsOnADriveTrainWithLoadFriction) {
  auto robot =
      nlohmann::json::parse(delta::read_whole_file(DELTA_SOURCE_DIR "/docs/examples/robot.json"));
  robot["upper_arm"]["mass_kg"] = 0.7;
  const double ratio[3] = {1.06, 0.95, 1.10};
  const double arm_scale[3] = {1.0, 1.03, 0.97};
  robot["upper_arms"] = nlohmann::json::array();
  for (unsigned j = 0; j < 3; ++j) {
    auto arm = robot["upper_arm"];
    arm["mass_kg"] = 0.7 * arm_scale[j];
    robot["upper_arms"].push_back(arm);
    robot["joints"][j]["torque_constant_ratio"] = ratio[j];
    robot["joints"][j]["load_friction_coefficient"] = 0.05;
  }
  delta::write_file_atomically(path("empty.json"), robot.dump());
  robot["payload"]["mass_kg"] = 0.5;
  delta::write_file_atomically(path("loaded.json"), robot.dump());
  for (const char* name : {"empty", "loaded"}) {
    ASSERT_EQ(run({"simulate", "--plant", "mujoco", "--robot", path(std::string(name) + ".json"),
                   "-o", path(std::string(name) + ".csv"), "--duration", "20", "--base-hz", "0.4",
                   "--torque-noise", "0.015", "--encoder-bits", "17", "--seed", "3", "--quiet"}),
              0)
        << err_.str();
  }
  ASSERT_EQ(run({"fit", path("empty.csv"), "--calibrate-torque", path("loaded.csv"),
                 "--payload-mass", "0.5", "--json"}),
            0)
      << err_.str();
  const auto j = nlohmann::json::parse(out_.str());
  for (unsigned k = 0; k < 3; ++k) {
    const double scale = j["torque_scale"][k].get<double>();
    EXPECT_NEAR(scale * ratio[k], 1.0, 0.005) << "joint " << k + 1;
    // Honest: the truth within 2 sigma, sigma at least least squares' own.
    const double sigma = j["torque_scale_std"][k].get<double>();
    EXPECT_LE(std::abs(scale - 1.0 / ratio[k]), 2.0 * sigma) << "joint " << k + 1;
    EXPECT_GE(sigma, j["torque_scale_ls_std"][k].get<double>()) << "joint " << k + 1;
  }
  EXPECT_EQ(j["model_terms"], "per-joint arms, load friction");
  ASSERT_EQ(run({"fit", path("empty.csv"), "--calibrate-torque", path("loaded.csv"),
                 "--payload-mass", "0.5"}),
            0)
      << err_.str();
  EXPECT_NE(out_.str().find("std dev   with model error"), std::string::npos) << out_.str();
  EXPECT_EQ(run({"fit", path("empty.csv"), "--calibrate-torque", path("loaded.csv"),
                 "--payload-mass", "0.5", "--torque-gains"}),
            2);
  EXPECT_NE(err_.str().find("leave out --torque-gains"), std::string::npos) << err_.str();
}

}  // namespace
}  // namespace host_id

namespace host_id {
namespace {

// fit --elastic on a log with the arm's encoders (simulate --arm-encoders):
// the stiffness in the report and the JSON, the elastic model saved where
// the log supports it, and predict reading it back; the lumped plant has no
// arm side to encode.
TEST_F(CliTest, ElasticGearboxesAreFittedFromTheArmsEncoders) {
  auto robot =
      nlohmann::json::parse(delta::read_whole_file(DELTA_SOURCE_DIR "/docs/examples/robot.json"));
  for (auto& joint : robot["joints"]) {
    joint["rotor_inertia_kg_m2"] = 3e-5;
    joint["gearbox_stiffness_Nm_per_rad"] = 1500.0;
  }
  delta::write_file_atomically(path("elastic.json"), robot.dump());
  ASSERT_EQ(
      run({"simulate", "--plant", "mujoco", "--robot", path("elastic.json"), "-o", path("e.csv"),
           "--duration", "8", "--base-hz", "0.4", "--arm-encoders", "--quiet"}),
      0)
      << err_.str();
  EXPECT_NE(delta::read_whole_file(path("e.csv")).find("qa1,qa2,qa3"), std::string::npos);
  // The follower's tracking, the motors' and the arms' (behind the gearbox).
  const DeltaLog simulated = read_delta_log(path("e.csv"));
  for (const char* key :
       {"tracking_rms_rad_1", "arm_tracking_rms_rad_3", "arm_tracking_max_rad_2"}) {
    ASSERT_TRUE(simulated.metadata_value(key).has_value()) << key;
    EXPECT_GT(std::stod(*simulated.metadata_value(key)), 1e-6) << key;
  }
  EXPECT_NE(std::stod(*simulated.metadata_value("tracking_rms_rad_1")),
            std::stod(*simulated.metadata_value("arm_tracking_rms_rad_1")));
  EXPECT_NE(out_.str().find("arm tracking: rms_rad="), std::string::npos) << out_.str();
  // The datasheet's stiffness, given: carried as it is, not searched.
  ASSERT_EQ(run({"fit", path("e.csv"), "--gearbox-stiffness", "1400,1500,1600", "--method", "ls",
                 "-o", path("given.json")}),
            0)
      << err_.str();
  EXPECT_NE(out_.str().find("elastic gearboxes K 1400, 1500, 1600 N m/rad"), std::string::npos)
      << out_.str();
  const auto given = nlohmann::json::parse(delta::read_whole_file(path("given.json")));
  EXPECT_NEAR(given["model"]["gearbox_compliance_rad_per_Nm"][2].get<double>(), 1.0 / 1600, 1e-12);
  EXPECT_EQ(run({"fit", path("e.csv"), "--gearbox-stiffness", "1400,1500"}), 2);
  EXPECT_NE(err_.str().find("one stiffness for all joints or three"), std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", path("e.csv"), "--gearbox-stiffness", "1500", "--elastic"}), 2);
  EXPECT_EQ(run({"fit", path("e.csv"), "--gearbox-stiffness", "-5"}), 2);
  EXPECT_EQ(run({"fit", path("e.csv"), "--gearbox-stiffness", "50"}), 2);
  EXPECT_NE(err_.str().find("softer than the controller runs"), std::string::npos) << err_.str();
  ASSERT_EQ(run({"fit", path("e.csv"), "--elastic", "--method", "ls", "-o", path("r.json")}), 0)
      << err_.str();
  EXPECT_NE(out_.str().find("gearbox stiffness K = 1 / c from the arm's encoders"),
            std::string::npos)
      << out_.str();
  EXPECT_EQ(err_.str().find("qa1"), std::string::npos) << "qa1..qa3 are read: " << err_.str();
  const auto saved = nlohmann::json::parse(delta::read_whole_file(path("r.json")));
  ASSERT_TRUE(saved["elasticity"].is_object());
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_NEAR(1.0 / saved["elasticity"]["compliance_rad_per_Nm"][j].get<double>(), 1500.0, 150.0);
  }
  EXPECT_EQ(saved["model"]["gearbox_compliance_rad_per_Nm"].size(), 3u);
  ASSERT_EQ(run({"predict", path("r.json"), path("e.csv"), "-o", path("p.csv")}), 0) << err_.str();
  EXPECT_EQ(run({"simulate", "-o", path("l.csv"), "--arm-encoders"}), 1);
  EXPECT_NE(err_.str().find("--arm-encoders goes with --plant mujoco"), std::string::npos)
      << err_.str();
}

}  // namespace
}  // namespace host_id

namespace host_id {
namespace {

// A simulated log's text with each data row passed through `edit` (its
// fields: seq, t, q1, q2, q3, tau1, tau2, tau3), and metadata lines
// containing `drop` left out.
std::string edited_log(const std::string& text,
                       const std::function<void(std::vector<std::string>&)>& edit,
                       const std::string& drop = "\x01") {
  std::istringstream in(text);
  std::string line, out;
  bool header = false;
  while (std::getline(in, line)) {
    if (line.rfind('#', 0) == 0) {
      if (line.find(drop) == std::string::npos) {
        out += line;
        out += '\n';
      }
      continue;
    }
    if (!header) {
      header = true;
      out += line;
      out += '\n';
      continue;
    }
    std::vector<std::string> f;
    std::istringstream fields(line);
    for (std::string v; std::getline(fields, v, ',');) f.push_back(v);
    edit(f);
    for (std::size_t i = 0; i < f.size(); ++i) {
      if (i != 0) out += ',';
      out += f[i];
    }
    out += '\n';
  }
  return out;
}

// Mistakes a user makes, each named for what it is: t written in
// milliseconds (with the rate declared, and without), a joint that never
// moved (its drive disabled for the whole run), torques in mN m, a stall
// (every drive off for a while mid-run).
TEST_F(CliTest, MillisecondsAndAStillJointAreNamed) {
  simulate("a.csv", {"--torque-noise", "0.01"});
  const std::string text = delta::read_whole_file(path("a.csv"));
  const auto in_ms = [](std::vector<std::string>& f) {
    f[1] = std::to_string(std::stod(f[1]) * 1000.0);
  };
  std::ofstream(path("ms.csv")) << edited_log(text, in_ms);
  EXPECT_EQ(run({"fit", path("ms.csv"), "--method", "ls"}), 1);
  EXPECT_NE(err_.str().find("t looks like milliseconds"), std::string::npos) << err_.str();
  std::ofstream(path("ms2.csv")) << edited_log(text, in_ms, "sample_rate_hz");
  EXPECT_EQ(run({"fit", path("ms2.csv"), "--method", "ls"}), 1);
  EXPECT_NE(err_.str().find("t looks like milliseconds (the median step is 1)"), std::string::npos)
      << err_.str();
  std::ofstream(path("still.csv")) << edited_log(text, [](std::vector<std::string>& f) {
    // q2 held, and no torque: the drive is off (to_string, not a literal:
    // GCC 12's -Wrestrict misreads a short literal's copy, bug 105329).
    f[3] = std::to_string(0.1);
    f[6] = std::to_string(0);
  });
  EXPECT_EQ(run({"fit", path("still.csv"), "--method", "ls"}), 1);
  EXPECT_NE(err_.str().find("joint 2 did not move: its angle spans 0 rad over the whole log"),
            std::string::npos)
      << err_.str();
  EXPECT_EQ(err_.str().find("lower --min-speed"), std::string::npos) << err_.str();
  // Torques in mN m: a fit, said to be doubtful for masses no such robot
  // has; the log as it is raises no such doubt.
  std::ofstream(path("mnm.csv")) << edited_log(text, [](std::vector<std::string>& f) {
    for (std::size_t i = 5; i < 8; ++i) f[i] = std::to_string(std::stod(f[i]) * 1000.0);
  });
  ASSERT_EQ(run({"fit", path("mnm.csv"), "--method", "ls"}), 0) << err_.str();
  EXPECT_NE(err_.str().find("the masses are implausible for this robot"), std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find("torque logged in mN m instead of N m"), std::string::npos);
  // A stall: the drives off from 2 s to 3.5 s, every torque 0.
  std::ofstream(path("stall.csv")) << edited_log(text, [](std::vector<std::string>& f) {
    const double t = std::stod(f[1]);
    if (t >= 2.0 && t <= 3.5) {
      for (std::size_t i = 5; i < 8; ++i) f[i] = std::to_string(0);
    }
  });
  ASSERT_EQ(run({"fit", path("stall.csv"), "--method", "ls"}), 0) << err_.str();
  EXPECT_NE(err_.str().find("warning: from t = 2 s to 3.5 s every joint's torque is 0"),
            std::string::npos)
      << err_.str();
  ASSERT_EQ(run({"fit", path("a.csv"), "--method", "ls"}), 0) << err_.str();
  EXPECT_EQ(err_.str().find("implausible"), std::string::npos) << err_.str();
  EXPECT_EQ(err_.str().find("every joint's torque is 0"), std::string::npos) << err_.str();
}

// One joint's torque or angle inverted (a drive or an encoder counting the
// other way): the fit is refused, naming the joint and the column, whether
// the default fit (--model auto, PSO) got through or not.
TEST_F(CliTest, AnInvertedJointIsNamedWithItsColumn) {
  simulate("a.csv", {"--torque-noise", "0.01"});
  const std::string text = delta::read_whole_file(path("a.csv"));
  const auto negate = [](std::size_t field) {
    return
        [field](std::vector<std::string>& f) { f[field] = std::to_string(-std::stod(f[field])); };
  };
  std::ofstream(path("tau2.csv")) << edited_log(text, negate(6));
  EXPECT_EQ(run({"fit", path("tau2.csv")}), 1);
  EXPECT_NE(err_.str().find("joint 2's torque looks opposite in sign"), std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find("Negate tau2"), std::string::npos) << err_.str();
  std::ofstream(path("q3.csv")) << edited_log(text, negate(4));
  EXPECT_EQ(run({"fit", path("q3.csv")}), 1);
  EXPECT_NE(err_.str().find("joint 3's angle looks opposite in sign"), std::string::npos)
      << err_.str();
  ASSERT_EQ(run({"fit", path("a.csv")}), 0) << err_.str();
  EXPECT_EQ(err_.str().find("opposite in sign"), std::string::npos) << err_.str();
}

// The friction's shape, named where the log shows it: the shipped robot
// (docs/examples/robot.json: Stribeck friction of 0.02 N m at 0.1 rad/s)
// leaves the Stribeck signature in the default fit's residual, and the fit
// says which --stribeck-velocity to fit with; with it, the doubt is gone.
// The same robot without the Stribeck term raises no such doubt. A friction
// shape searched to its bound (a robot whose Coulomb friction is smoothed
// over 0.5 rad/s, beyond the search's 0.2) is doubtful.
TEST_F(CliTest, TheStribeckSignatureAndAShapeAtItsBoundAreNamed) {
  auto robot =
      nlohmann::json::parse(delta::read_whole_file(DELTA_SOURCE_DIR "/docs/examples/robot.json"));
  const auto multibody_log = [&](const std::string& name) {
    delta::write_file_atomically(path(name + ".json"), robot.dump());
    ASSERT_EQ(run({"simulate", "--plant", "mujoco", "--robot", path(name + ".json"), "-o",
                   path(name + ".csv"), "--duration", "20", "--base-hz", "0.4", "--torque-noise",
                   "0.015", "--encoder-bits", "17", "--seed", "3", "--quiet"}),
              0)
        << err_.str();
  };
  multibody_log("stribeck");
  ASSERT_EQ(run({"fit", path("stribeck.csv"), "--method", "ls"}), 0) << err_.str();
  EXPECT_NE(err_.str().find("the residual has the Stribeck signature"), std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find("Fit with --stribeck-velocity 0.1"), std::string::npos) << err_.str();
  ASSERT_EQ(run({"fit", path("stribeck.csv"), "--method", "ls", "--stribeck-velocity", "0.1"}), 0);
  EXPECT_EQ(err_.str().find("Stribeck signature"), std::string::npos) << err_.str();
  for (auto& joint : robot["joints"]) joint["stribeck_friction_Nm"] = 0.0;
  multibody_log("plain");
  ASSERT_EQ(run({"fit", path("plain.csv"), "--method", "ls"}), 0) << err_.str();
  EXPECT_EQ(err_.str().find("Stribeck signature"), std::string::npos) << err_.str();
  for (auto& joint : robot["joints"]) joint["friction_smoothing_rad_s"] = 0.5;
  multibody_log("smooth");
  ASSERT_EQ(run({"fit", path("smooth.csv"), "--method", "ls", "--fit-friction-shape"}), 0);
  EXPECT_NE(err_.str().find("the friction shape's search ended on its bound (Coulomb smoothing"),
            std::string::npos)
      << err_.str();
}

// Two runs glued into one log, the second with a 0.5 kg payload (its seq
// and t carried on): the platform's masses and the gravity moments change
// along the log, and the fit says so; either run alone raises no such doubt.
TEST_F(CliTest, RunsGluedIntoOneLogAreNamed) {
  auto robot =
      nlohmann::json::parse(delta::read_whole_file(DELTA_SOURCE_DIR "/docs/examples/robot.json"));
  std::string texts[2];
  for (int k = 0; k < 2; ++k) {
    robot["payload"]["mass_kg"] = 0.5 * k;
    const std::string name = "run" + std::to_string(k);
    delta::write_file_atomically(path(name + ".json"), robot.dump());
    ASSERT_EQ(run({"simulate", "--plant", "mujoco", "--robot", path(name + ".json"), "-o",
                   path(name + ".csv"), "--duration", "10", "--base-hz", "0.4", "--torque-noise",
                   "0.015", "--encoder-bits", "17", "--seed", "3", "--quiet"}),
              0)
        << err_.str();
    texts[k] = delta::read_whole_file(path(name + ".csv"));
  }
  ASSERT_EQ(run({"fit", path("run1.csv"), "--method", "ls"}), 0) << err_.str();
  EXPECT_EQ(err_.str().find("change along the log"), std::string::npos) << err_.str();
  // The second run's rows after the first's, 10 s and 10001 samples on.
  std::string glued = texts[0];
  const std::string second = edited_log(texts[1], [](std::vector<std::string>& f) {
    f[0] = std::to_string(std::stoull(f[0]) + 10001);
    f[1] = std::to_string(std::stod(f[1]) + 10.001);
  });
  const std::size_t header = second.find("seq,");
  glued += second.substr(second.find('\n', header) + 1);
  std::ofstream(path("glued.csv")) << glued;
  ASSERT_EQ(run({"fit", path("glued.csv"), "--method", "ls"}), 0) << err_.str();
  EXPECT_NE(err_.str().find("platform_inertial_mass, platform_weight_mass change along the log"),
            std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find("fit each run alone"), std::string::npos) << err_.str();
}

// A validation log that moves far faster than the fitted one (the same
// Fourier path at four times the frequency: speeds 4 times, accelerations
// 16 times) is named extrapolation by fit --validate, validate and
// predict, with both ranges; a log of the same motion is not.
TEST_F(CliTest, AValidationLogBeyondTheFittedMotionIsNamedExtrapolation) {
  simulate("slow.csv", {"--torque-noise", "0.01"});
  simulate("again.csv", {"--torque-noise", "0.01", "--seed", "2"});
  simulate("fast.csv", {"--torque-noise", "0.01", "--base-hz", "0.8"});
  ASSERT_EQ(run({"fit", path("slow.csv"), "--method", "ls", "--validate", path("again.csv"),
                 "--validate", path("fast.csv"), "-o", path("slow.json")}),
            0)
      << err_.str();
  const std::string fit_err = err_.str();
  EXPECT_NE(fit_err.find(path("fast.csv") + ": warning: this log goes beyond the motion the fit"),
            std::string::npos)
      << fit_err;
  EXPECT_NE(fit_err.find("speed up to"), std::string::npos) << fit_err;
  EXPECT_EQ(fit_err.find(path("again.csv") + ": warning"), std::string::npos) << fit_err;
  ASSERT_EQ(run({"validate", path("slow.json"), path("fast.csv")}), 0) << err_.str();
  EXPECT_NE(err_.str().find("extrapolation"), std::string::npos) << err_.str();
  ASSERT_EQ(run({"predict", path("slow.json"), path("fast.csv"), "-o", path("p.csv")}), 0);
  EXPECT_NE(err_.str().find("extrapolation"), std::string::npos) << err_.str();
  ASSERT_EQ(run({"predict", path("slow.json"), path("again.csv"), "-o", path("q.csv")}), 0);
  EXPECT_EQ(err_.str().find("extrapolation"), std::string::npos) << err_.str();
}

}  // namespace
}  // namespace host_id
