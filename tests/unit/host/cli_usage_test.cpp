// host_id's usage and input errors: misspelt commands and options, bad
// values and logs, outputs that cannot be written, --version, the DBC.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "cli_fixture.hpp"
#include "delta/atomic_file.hpp"
#include "delta/input_error.hpp"
#include "delta/read_file.hpp"
#include "host_id/identify.hpp"

namespace host_id {
namespace {

using cli_test::CliTest;

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

TEST_F(CliTest, ValidateRejectsWhatIsNotAResult) {
  simulate("p1.csv");
  std::ofstream(path("x.json")) << "{\"format\": \"something-else\"}";
  EXPECT_EQ(run({"validate", path("x.json"), path("p1.csv")}), 1);
  EXPECT_NE(err_.str().find("not a host_id result"), std::string::npos);
  std::ofstream(path("y.json")) << "{not json";
  EXPECT_EQ(run({"validate", path("y.json"), path("p1.csv")}), 1);
  EXPECT_NE(err_.str().find("y.json:1:3: not valid JSON"), std::string::npos);
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

}  // namespace
}  // namespace host_id
