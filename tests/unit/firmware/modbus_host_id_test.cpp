// host_id status and excite against the firmware's Modbus server.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

#include "delta/atomic_file.hpp"
#include "host_id/cli.hpp"
#include "modbus_fixture.hpp"
#include "scratch_directory.hpp"

namespace fw_linux {
namespace {

namespace mb = delta::modbus;
using modbus_test::Fixture;
using modbus_test::path1_as_custom;
using modbus_test::poll_until;
using modbus_test::value;

TEST_F(Fixture, HostIdStatusReadsTheController) {
  std::ostringstream out, err;
  const std::string address = "127.0.0.1:" + std::to_string(server.tcp_port());
  ASSERT_EQ(host_id::run_cli({"status", "--modbus", address}, out, err), 0) << err.str();
  const std::string s = out.str();
  EXPECT_NE(s.find("controller " + address + ": firmware "), std::string::npos) << s;
  EXPECT_NE(s.find("  state      ready\n"), std::string::npos) << s;
  EXPECT_NE(s.find("settings   trajectory path1, amplitude 100.0 %, repetitions preset"),
            std::string::npos)
      << s;
  EXPECT_NE(s.find("upper arm 0.2000 m"), std::string::npos) << s;
  // --json: every register by name.
  std::ostringstream json;
  ASSERT_EQ(host_id::run_cli({"status", "--modbus", address, "--json"}, json, err), 0);
  EXPECT_NE(json.str().find("\"period_us\": 2000"), std::string::npos) << json.str();
  // Errors: nobody listening, a malformed address.
  std::ostringstream e1, e2, o;
  EXPECT_EQ(host_id::run_cli({"status", "--modbus", "127.0.0.1:1"}, o, e1), 1);
  EXPECT_NE(e1.str().find("cannot connect to the controller at 127.0.0.1:1"), std::string::npos)
      << e1.str();
  EXPECT_EQ(host_id::run_cli({"status", "--modbus", "localhost"}, o, e2), 2);
  EXPECT_NE(e2.str().find("expected HOST:PORT"), std::string::npos) << e2.str();
}

TEST_F(Fixture, HostIdExciteRefusesBadArgumentsAndAControllerInFault) {
  const std::string address = "127.0.0.1:" + std::to_string(server.tcp_port());
  std::ostringstream o, e1, e2, e3;
  EXPECT_EQ(host_id::run_cli({"excite", "--modbus", address, "--trajectory", "figure8", "--can",
                              "vcan0", "-o", "x.csv"},
                             o, e1),
            2);
  EXPECT_NE(e1.str().find("--trajectory: figure8 not in {path1,path2,pick-and-place,custom}"),
            std::string::npos)
      << e1.str();
  EXPECT_EQ(host_id::run_cli({"excite", "--modbus", address, "--trajectory", "path1", "--can",
                              "vcan0", "-o", "x.csv", "--amplitude-scale", "3"},
                             o, e2),
            2);
  EXPECT_NE(e2.str().find("--amplitude-scale: must be in [0.001, 2], got '3'"), std::string::npos)
      << e2.str();
  loop.io().open_estop(true);
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* x) {
    return value(x, "state") == static_cast<int>(fw::State::kFault);
  }));
  EXPECT_EQ(
      host_id::run_cli({"excite", "--modbus", address, "--trajectory", "path1", "--can", "vcan0",
                        "-o", testsupport::process_scratch("modbus_test").file("x.csv")},
                       o, e3),
      1);
  EXPECT_NE(e3.str().find("is in fault 1 (e-stop)"), std::string::npos) << e3.str();
  EXPECT_FALSE(std::ifstream(testsupport::process_scratch("modbus_test").file("x.csv")).good());
}

// excite --trajectory-file uploads the file as the custom trajectory; the
// controller's refusal comes back with the limit and the tick, and nothing
// is recorded or written.
TEST_F(Fixture, HostIdExciteUploadsATrajectoryFileAndReportsItsRefusal) {
  const std::string address = "127.0.0.1:" + std::to_string(server.tcp_port());
  const std::string dir = testsupport::process_scratch("modbus_test").path();
  delta::write_file_atomically(dir + "/fast.json",
                               delta::format_trajectory(path1_as_custom(5.0), ""));
  std::ostringstream o, e1, e2, e3;
  EXPECT_EQ(host_id::run_cli({"excite", "--modbus", address, "--trajectory-file",
                              dir + "/fast.json", "--can", "vcan0", "-o", dir + "/f.csv"},
                             o, e1),
            1);
  EXPECT_NE(e1.str().find("the trajectory with these settings breaks a limit (register "
                          "trajectory, Modbus exception 3): "),
            std::string::npos)
      << e1.str();
  EXPECT_NE(e1.str().find(" at tick "), std::string::npos) << e1.str();
  EXPECT_FALSE(std::ifstream(dir + "/f.csv").good());
  // The block was taken (the check runs when it is selected).
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kTrajectoryLimit));
  EXPECT_EQ(
      host_id::run_cli({"excite", "--modbus", address, "--trajectory", "path1", "--trajectory-file",
                        dir + "/fast.json", "--can", "vcan0", "-o", dir + "/f.csv"},
                       o, e2),
      2);
  EXPECT_EQ(host_id::run_cli(
                {"excite", "--modbus", address, "--can", "vcan0", "-o", dir + "/f.csv"}, o, e3),
            2);
  EXPECT_NE(e3.str().find("one of --trajectory and --trajectory-file is required"),
            std::string::npos)
      << e3.str();
}

TEST(HostIdExcite, PartialLogNames) {
  EXPECT_EQ(delta::partial_log_path("run.csv"), "run.partial.csv");
  EXPECT_EQ(delta::partial_log_path("/data/v1.2/run.csv"), "/data/v1.2/run.partial.csv");
  EXPECT_EQ(delta::partial_log_path("/data/v1.2/run"), "/data/v1.2/run.partial");
  EXPECT_EQ(delta::partial_log_path(".hidden"), ".hidden.partial");
}

}  // namespace
}  // namespace fw_linux
