// host_id sdo on vcan against the real nodes: the controller (delta_fw) and
// an emulated drive.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <tuple>
#include <vector>

#include "bus_observer.hpp"
#include "child_process.hpp"
#include "pipeline_programs.hpp"

namespace {

using hil::kBin;
using hil::kIface;
using hil::start_emulator;
using hil::u16;
using namespace std::chrono_literals;

// host_id sdo against the real nodes on vcan: the controller's node 16
// (delta_fw running) and an emulated drive; expedited, segmented and block
// uploads, a download, an abort with its meaning, and a node that is not
// there.
TEST(SdoTool, ReadsAndWritesTheControllersAndADrivesObjects) {
  hil::Child emu = start_emulator({"--plant", "lumped"});
  hil::Child fw = hil::Child::spawn({kBin + "/delta_fw", "--can", kIface, "--lockstep"});
  ASSERT_TRUE(fw.wait_for_output("delta_fw: ready", 60s)) << fw.err();
  const auto sdo = [](std::vector<std::string> args) {
    std::vector<std::string> argv{kBin + "/host_id", "sdo"};
    argv.insert(argv.end(), args.begin(), args.end());
    argv.insert(argv.end(), {"--can", kIface});
    hil::Child c = hil::Child::spawn(argv);
    const int code = c.wait(60s).value_or(-1);
    return std::tuple{code, c.out(), c.err()};
  };
  auto [code, out, err] = sdo({"read", "0x1008", "--node", "16"});  // segmented: 8 bytes
  EXPECT_EQ(code, 0) << err;
  EXPECT_EQ(out, "delta_fw\n");
  std::tie(code, out, err) = sdo({"read", "0x1018:2", "--node", "16"});
  EXPECT_EQ(out, "22 (0x00000016)\n") << err;
  std::tie(code, out, err) = sdo({"read", "0x1008", "--node", "2", "--block"});
  EXPECT_EQ(out, "Delta emulated CiA 402 drive\n") << err;
  std::tie(code, out, err) = sdo({"write", "0x1017", "200", "--type", "u16", "--node", "16"});
  EXPECT_EQ(code, 0) << err;
  std::tie(code, out, err) = sdo({"read", "0x1017", "--node", "16", "--type", "u16"});
  EXPECT_EQ(out, "200 (0x00C8)\n") << err;
  EXPECT_NE(err.find("bytes read in"), std::string::npos) << err;
  // For scripts: --json, and --quiet without the transfer line.
  std::tie(code, out, err) = sdo({"read", "0x1017", "--node", "16", "--type", "u16", "--json"});
  EXPECT_EQ(code, 0) << err;
  EXPECT_NE(out.find("\"object\": \"0x1017:00\""), std::string::npos) << out;
  EXPECT_NE(out.find("\"value\": \"200 (0x00C8)\""), std::string::npos) << out;
  std::tie(code, out, err) = sdo({"read", "0x1017", "--node", "16", "--type", "u16", "--quiet"});
  EXPECT_EQ(out, "200 (0x00C8)\n");
  EXPECT_EQ(err, "");
  std::tie(code, out, err) = sdo({"read", "0x2000", "--node", "16"});
  EXPECT_EQ(code, 3);
  EXPECT_NE(err.find("node 16, 0x2000:00: the node aborted the transfer: 0x06020000 (object does "
                     "not exist in the object dictionary)"),
            std::string::npos)
      << err;
  std::tie(code, out, err) = sdo({"read", "0x1000", "--node", "42", "--timeout-ms", "200"});
  EXPECT_EQ(code, 4);
  EXPECT_NE(err.find("node 42, 0x1000:00: no answer within 200 ms"), std::string::npos) << err;
  fw.terminate(60s);
  emu.terminate(30s);
}

}  // namespace
