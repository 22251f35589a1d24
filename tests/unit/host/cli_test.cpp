// The command line end to end, through run_cli() with real files.
#include "host_id/cli.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "delta/atomic_file.hpp"
#include "delta/input_error.hpp"
#include "delta/read_file.hpp"
#include "delta/trajectory_file.hpp"
#include "held_joint_log.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"
#include "host_id/simulate.hpp"
#include "scratch_directory.hpp"

namespace host_id {
namespace {

class CliTest : public ::testing::Test {
 protected:
  int run(const std::vector<std::string>& args) {
    out_.str("");
    err_.str("");
    return run_cli(args, out_, err_);
  }
  std::string path(const std::string& name) const { return dir_ + "/" + name; }
  bool exists(const std::string& name) const { return std::filesystem::exists(path(name)); }
  void simulate(const std::string& name, const std::vector<std::string>& extra = {}) {
    std::vector<std::string> args{"simulate", "-o", path(name), "--duration", "4"};
    args.insert(args.end(), extra.begin(), extra.end());
    ASSERT_EQ(run(args), 0) << err_.str();
  }
  // A lumped log of arms whose inertias and gravity moments differ by up to
  // 5 % (simulate --params with per-joint values).
  void simulate_arms_that_differ(const std::string& name) {
    std::ofstream(path("arms.json"))
        << R"({"arm_inertia_1": 0.0076, "arm_inertia_2": 0.0072, "arm_inertia_3": 0.0068,
               "arm_gravity_moment_1": 0.42, "arm_gravity_moment_2": 0.44,
               "arm_gravity_moment_3": 0.46, "platform_mass": 0.4})";
    simulate(name, {"--params", path("arms.json"), "--torque-noise", "0.01"});
  }

  const testsupport::ScratchDirectory scratch_{"host_id_cli"};
  const std::string dir_ = scratch_.path();
  std::ostringstream out_, err_;
};

// A misspelt command or option gets the nearest real one named.
TEST_F(CliTest, AMisspeltCommandOrOptionIsAnsweredWithTheNearestOne) {
  EXPECT_EQ(run({"fti", "log.csv"}), 2);
  EXPECT_NE(err_.str().find("unknown command 'fti' (did you mean 'fit'?)"), std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"xyz"}), 2);
  EXPECT_EQ(err_.str().find("did you mean"), std::string::npos) << err_.str();
  EXPECT_EQ(run({"fit", "docs/examples/path1.csv", "--metod", "ls"}), 2);
  EXPECT_NE(err_.str().find("(did you mean --method?)"), std::string::npos) << err_.str();
  EXPECT_EQ(run({"simulate", "--duraton", "2", "-o", path("s.csv")}), 2);
  EXPECT_NE(err_.str().find("(did you mean --duration?)"), std::string::npos) << err_.str();
  EXPECT_FALSE(std::filesystem::exists(path("s.csv")));
}

// An output that cannot be written is refused before any work, with the
// reason; fit takes -o like the other commands.
TEST_F(CliTest, AnOutputThatCannotBeWrittenIsRefusedBeforeTheWork) {
  const std::string log = "docs/examples/path1.csv";
  EXPECT_EQ(run({"fit", log, "--method", "ls", "-o", path("no/such/folder/r.json")}), 2);
  EXPECT_NE(err_.str().find("host_id fit: error: --out: cannot write '" +
                            path("no/such/folder/r.json") + "': the folder '" +
                            path("no/such/folder") + "' does not exist (create it first)"),
            std::string::npos)
      << err_.str();
  EXPECT_EQ(out_.str(), "");  // no fit was made
  EXPECT_EQ(run({"simulate", "--duration", "1", "-o", dir_}), 2);
  EXPECT_NE(err_.str().find("host_id simulate: error: --out: '" + dir_ +
                            "' is a folder; give a file name"),
            std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", log, "--method", "ls", "--plot", path("none/fit.svg")}), 2);
  EXPECT_NE(err_.str().find("host_id fit: error: --plot: cannot write"), std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", log, "--method", "ls", "--quiet", "-o", path("r.json")}), 0) << err_.str();
  EXPECT_TRUE(std::filesystem::exists(path("r.json")));
}

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

TEST_F(CliTest, NoArgumentsPrintsUsageAndFails) {
  EXPECT_EQ(run({}), 2);
  EXPECT_NE(err_.str().find("Usage: host_id [OPTIONS] SUBCOMMAND"), std::string::npos)
      << err_.str();
  EXPECT_NE(err_.str().find("host_id: error: A subcommand is required"), std::string::npos);
  EXPECT_EQ(run({"--help"}), 0);
  EXPECT_NE(out_.str().find("record"), std::string::npos);
  // Short: a line a command, none wider than a terminal's 100 columns
  // (the first, the program's description, wraps as a paragraph).
  std::istringstream help(out_.str());
  std::string line;
  std::getline(help, line);
  while (std::getline(help, line)) EXPECT_LE(line.size(), 100u) << line;
  EXPECT_EQ(run({"fit", "--help"}), 0);
  EXPECT_NE(out_.str().find("--validate"), std::string::npos);
  // The documented default of --min-speed is the code's.
  EXPECT_NE(out_.str().find("(delta: 0.05,"), std::string::npos) << out_.str();
  EXPECT_NEAR(min_speed_for(FitOptions{}), 0.05, 0.0);
}

// The version is the project's, which the firmware reports in its version
// registers; every command takes --version.
TEST_F(CliTest, VersionIsPrintedByTheProgramAndEveryCommand) {
  const std::string expected = std::string("host_id ") + DELTA_PROJECT_VERSION + "\n";
  EXPECT_EQ(run({"--version"}), 0);
  EXPECT_EQ(out_.str(), expected);
  for (const char* command :
       {"fit", "validate", "predict", "design", "simulate", "record", "excite", "status", "dbc"}) {
    EXPECT_EQ(run({command, "--version"}), 0) << command;
    EXPECT_EQ(out_.str(), expected) << command;
  }
}

TEST_F(CliTest, BadOptionsAreNamedWithExitStatusTwo) {
  simulate("a.csv");
  EXPECT_EQ(run({"frobnicate"}), 2);
  EXPECT_NE(err_.str().find("unknown command 'frobnicate'"), std::string::npos);
  EXPECT_EQ(run({"fit", path("a.csv"), "--itertions", "5"}), 2);
  EXPECT_EQ(err_.str(),
            "host_id fit: error: The following arguments were not expected: 5 --itertions (did "
            "you mean --iterations?) (see host_id fit --help)\n");
  EXPECT_EQ(run({"fit", path("a.csv"), "--iterations", "many"}), 2);
  EXPECT_NE(err_.str().find("host_id fit: error: --iterations: Value many not in range 1 to "
                            "100000000"),
            std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--iterations", "0"}), 2);
  EXPECT_NE(err_.str().find("--iterations: Value 0 not in range 1 to 100000000"), std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--model", "paper"}), 2);
  EXPECT_NE(err_.str().find("--model: paper not in {delta,lumped,paper14,auto}"), std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--seed"}), 2);
  EXPECT_NE(err_.str().find("--seed"), std::string::npos);
  EXPECT_EQ(run({"fit", path("a.csv"), "--seed", "1", "--seed", "2"}), 2);
  EXPECT_EQ(run({"fit", path("a.csv"), "--cutoff-hz", "inf"}), 2);
  EXPECT_NE(err_.str().find("--cutoff-hz: expects a finite number, got 'inf'"), std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit"}), 2);
  EXPECT_NE(err_.str().find("log is required"), std::string::npos) << err_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--plot", path("p.png")}), 2);
  EXPECT_NE(err_.str().find("--plot: writes SVG"), std::string::npos) << err_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--model", "paper14", "--offsets"}), 1);
  EXPECT_NE(err_.str().find("--offsets applies to --model delta and lumped only"),
            std::string::npos);
  EXPECT_EQ(run({"fit", path("a.csv"), "--model", "paper14", "--fit-friction-shape"}), 1);
  EXPECT_NE(err_.str().find("--fit-friction-shape applies to --model delta and lumped only"),
            std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--model", "paper14", "--stribeck-velocity", "0.1"}), 1);
  EXPECT_NE(err_.str().find("--stribeck-velocity applies to --model delta and lumped only"),
            std::string::npos)
      << err_.str();
  EXPECT_EQ(run({"fit", path("a.csv"), "--stribeck-velocity", "-1"}), 2);
}

// Found when the product was tried as a new user would: values out of range
// and missing limits are usage errors (2), not input errors (1).
TEST_F(CliTest, OutOfRangeValuesAndMissingLimitsExitTwo) {
  EXPECT_EQ(run({"record", "--can", "vcan0", "-o", path("r.csv")}), 2);
  EXPECT_NE(err_.str().find("record: give a limit"), std::string::npos) << err_.str();
  EXPECT_EQ(run({"record", "--can", "vcan0", "-o", path("r.csv"), "--idle", "-1"}), 2);
  EXPECT_NE(err_.str().find("--idle: must be > 0, got '-1'"), std::string::npos) << err_.str();
  EXPECT_EQ(run({"status", "--modbus", "nohostport"}), 2);
  EXPECT_NE(err_.str().find("expected HOST:PORT, got 'nohostport'"), std::string::npos);
  EXPECT_EQ(run({"status", "--modbus", "127.0.0.1:99999"}), 2);
  EXPECT_NE(err_.str().find("the port must be a number from 1 to 65535, got '99999'"),
            std::string::npos);
  EXPECT_EQ(run({"excite", "--modbus", "127.0.0.1:0", "--trajectory", "path1", "--can", "vcan0",
                 "-o", path("x.csv")}),
            2);
  EXPECT_EQ(run({"simulate", "-o", path("s.csv"), "--rate", "0"}), 2);
  EXPECT_NE(err_.str().find("--rate: must be in [1, 100000], got '0'"), std::string::npos)
      << err_.str();
  EXPECT_FALSE(exists("r.csv"));
  EXPECT_FALSE(exists("s.csv"));
}

TEST_F(CliTest, BadLogFailsWithFileLineColumnAndWritesNothing) {
  std::ofstream(path("bad.csv")) << "# format = delta-log/1\n# upper_arm_length_m = 0.2\n"
                                    "# forearm_length_m = 0.46\n# base_radius_m = 0.1\n"
                                    "# platform_radius_m = 0.035\nt,q1,q2,q3,tau1,tau2,tau3\n"
                                    "0,0.3,0.3,0.3,-1,-1,-1\n0.001,0.3,0.3,0.3,-1,NaN,-1\n";
  EXPECT_EQ(run({"fit", path("bad.csv"), "--out", path("r.json"), "--plot", path("p.svg")}), 1);
  EXPECT_EQ(err_.str(), "host_id fit: error: " + path("bad.csv") +
                            ":8:22: column 'tau2': NaN or Inf is not allowed\n");
  EXPECT_FALSE(exists("r.json"));
  EXPECT_FALSE(exists("p.svg"));
  // A bad validation log fails before any work is done.
  simulate("a.csv");
  EXPECT_EQ(run({"fit", path("a.csv"), "--validate", path("missing.csv"), "--out", path("r.json")}),
            1);
  EXPECT_NE(err_.str().find("missing.csv: cannot open"), std::string::npos);
  EXPECT_FALSE(exists("r.json"));
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
  ASSERT_TRUE(j.contains("model_selection"));
  EXPECT_EQ(j["model_selection"]["folds"], 5);
  EXPECT_EQ(j["model_selection"]["variants"].size(), 4u);
  EXPECT_EQ(j["model_selection"]["chosen"], "shared arms");  // the default robot's arms are equal
  EXPECT_EQ(j["model"]["name"], "delta");
  EXPECT_EQ(j["model"]["per_joint"], false);
  ASSERT_EQ(run({"fit", path("p1.csv"), "--model", "auto", "--method", "ls"}), 0) << err_.str();
  EXPECT_NE(out_.str().find("<- chosen"), std::string::npos) << out_.str();
  EXPECT_EQ(run({"fit", path("p1.csv"), "--model", "auto", "--per-joint"}), 2);
  EXPECT_NE(err_.str().find("--model auto decides --per-joint and --offsets itself"),
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
  EXPECT_EQ(j["model_selection"]["chosen"], "per-joint arms");
  EXPECT_EQ(j["model"]["name"], "delta");
  EXPECT_EQ(j["model"]["per_joint"], true);
  EXPECT_EQ(j["parameters"].size(), 18u);
  EXPECT_EQ(j["model_support"]["chosen"], "per-joint arms");
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

TEST_F(CliTest, ValidateRejectsWhatIsNotAResult) {
  simulate("p1.csv");
  std::ofstream(path("x.json")) << "{\"format\": \"something-else\"}";
  EXPECT_EQ(run({"validate", path("x.json"), path("p1.csv")}), 1);
  EXPECT_NE(err_.str().find("not a host_id result"), std::string::npos);
  std::ofstream(path("y.json")) << "{not json";
  EXPECT_EQ(run({"validate", path("y.json"), path("p1.csv")}), 1);
  EXPECT_NE(err_.str().find("y.json:1:3: not valid JSON"), std::string::npos);
}

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

TEST_F(CliTest, TheShippedDbcIsTheOneTheProtocolTableGives) {
  ASSERT_EQ(run({"dbc"}), 0);
  EXPECT_EQ(out_.str(), delta::read_whole_file("docs/delta.dbc"))
      << "docs/delta.dbc is stale: regenerate it with host_id dbc -o docs/delta.dbc";
  EXPECT_NE(out_.str().find("BO_ 400 LOG_A: 8 Controller"), std::string::npos);
  EXPECT_NE(out_.str().find(" SG_ q1 : 16|24@1- (9.5367431640625e-07,0)"), std::string::npos);
  ASSERT_EQ(run({"dbc", "-o", path("bus.dbc")}), 0);
  EXPECT_EQ(delta::read_whole_file(path("bus.dbc")), delta::read_whole_file("docs/delta.dbc"));
}

TEST_F(CliTest, AtomicWriteLeavesTheOldFileWhenItFails) {
  std::ofstream(path("keep.txt")) << "old";
  delta::write_file_atomically(path("keep.txt"), "new");
  EXPECT_EQ(delta::read_whole_file(path("keep.txt")), "new");
  EXPECT_THROW(delta::write_file_atomically(path("no/such/dir/f.txt"), "x"), delta::InputError);
  // Only the written file is left: no temporary files.
  std::size_t files = 0;
  for (const auto& e : std::filesystem::directory_iterator(dir_)) {
    (void)e;
    ++files;
  }
  EXPECT_EQ(files, 1u);
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
TEST_F(CliTest, SimulateSummarisesAsJson) {
  ASSERT_EQ(run({"simulate", "-o", path("s.csv"), "--duration", "2", "--json"}), 0) << err_.str();
  const auto j = nlohmann::json::parse(out_.str());
  EXPECT_EQ(j["out"], path("s.csv"));
  EXPECT_EQ(j["samples"], 2001);
  EXPECT_EQ(j["plant"], "lumped");
  EXPECT_EQ(j["trajectory"], "fourier");
  EXPECT_EQ(read_delta_log(path("s.csv")).size(), 2001u);
}

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
