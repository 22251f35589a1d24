// Drives on the bus brought up from their EDS files, on vcan with the real
// programs: a drive of another product refused by its identity, and the
// drives users own (docs/drives.md) run from their own files.
#include <gtest/gtest.h>

#include <chrono>
#include <iostream>
#include <ostream>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "pipeline_programs.hpp"

namespace {

using hil::kBin;
using hil::kIface;
using hil::kSource;
using hil::start_emulator;
using hil::start_path1_firmware;
using namespace std::chrono_literals;

// Bring-up against the drive on the bus (real programs on vcan): the
// emulator runs as the second product (docs/eds/delta_drive_emu_b.eds); a
// controller configured with the first product's EDS for joint 2 refuses it
// naming node, object and both values; configured with the second's, the
// drives come up.
TEST(DriveIdentity, ADriveOfAnotherProductIsRefusedAndItsOwnEdsBringsItUp) {
  const std::string a = kSource + "/docs/eds/delta_drive_emu.eds";
  const std::string b = kSource + "/docs/eds/delta_drive_emu_b.eds";
  hil::Child emu = start_emulator({"--plant", "lumped", "--eds", b});
  hil::Child wrong = hil::Child::spawn({kBin + "/delta_fw", "--can", kIface, "--lockstep", "--run",
                                        "path1", "--exit-when-done", "--set", "joint2.eds=" + a});
  EXPECT_EQ(wrong.wait(120s).value_or(-1), 3) << wrong.err();
  EXPECT_NE(wrong.err().find("fault 10 ("), std::string::npos) << wrong.err();
  EXPECT_NE(wrong.err().find("node 2, 0x1018:02: product code 0x00000403; joint2.eds = " + a +
                             " expects 0x00000402"),
            std::string::npos)
      << wrong.err();
  hil::Child right = hil::Child::spawn({kBin + "/delta_fw", "--can", kIface, "--lockstep", "--run",
                                        "path1", "--exit-when-done", "--set", "joint1.eds=" + b,
                                        "--set", "joint2.eds=" + b, "--set", "joint3.eds=" + b});
  EXPECT_TRUE(right.wait_for_output("delta_fw: running\n", 60s)) << right.err();
  EXPECT_EQ(right.terminate(60s).value_or(-1), 5) << right.err();
  emu.terminate(30s);
}

// Drives users own (docs/drives.md), on vcan with the real programs: the
// emulator behaves as each accepted corpus drive's own file describes
// (tests/data/drives/), delta_fw plans its bring-up from the same file and
// runs path1 to the end; the time to ready is printed. A drive that cannot
// serve is refused before the bus, with its reason.
struct CorpusDrive {
  const char* file;
  std::vector<std::string> keys;  // --set for each joint, N for its number
  std::vector<std::string> emulator;
};

std::ostream& operator<<(std::ostream& os, const CorpusDrive& d) {
  return os << d.file;
}

class DrivesUsersOwn : public ::testing::TestWithParam<CorpusDrive> {};

TEST_P(DrivesUsersOwn, EachComesUpFromItsOwnFileAndRunsPath1ToTheEnd) {
  const CorpusDrive& d = GetParam();
  const std::string file = kSource + "/tests/data/drives/" + d.file;
  std::vector<std::string> emu_args{"--plant", "lumped", "--eds", file};
  emu_args.insert(emu_args.end(), d.emulator.begin(), d.emulator.end());
  hil::Child emu = start_emulator(emu_args);
  EXPECT_NE(emu.out().find("with an emulated behaviour"), std::string::npos) << emu.out();
  std::vector<std::string> sets;
  for (const char n : {'1', '2', '3'}) {
    std::vector<std::string> keys = d.keys;
    keys.push_back("jointN.eds=" + file);
    for (std::string k : keys) {
      k[5] = n;
      sets.insert(sets.end(), {"--set", k});
    }
  }
  const auto start = std::chrono::steady_clock::now();
  hil::Child fw = start_path1_firmware(sets, 1);  // bring-up is the point: one period
  ASSERT_TRUE(fw.wait_for_output("delta_fw: ready", 60s)) << fw.err();
  const double ready_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_EQ(fw.wait(300s).value_or(-1), 0) << fw.err();
  std::cout << "[ vcan ] " << d.file << ": ready " << ready_s
            << " s after delta_fw started (bring-up of three drives by SDO); path1 (one period) "
               "ran to the end\n";
  emu.terminate(30s);
}

INSTANTIATE_TEST_SUITE_P(
    Corpus, DrivesUsersOwn,
    ::testing::Values(
        CorpusDrive{
            "epos4.eds", {"jointN.rated_torque_Nm=0.2", "jointN.counts_per_rev=131072"}, {}},
        CorpusDrive{"tmcm_bldc.eds",
                    {"jointN.torque_unit=mA", "jointN.rated_torque_Nm=0.2"},
                    {"--torque-unit", "mA"}},
        CorpusDrive{"ipos.eds", {"jointN.rated_current_A=2", "jointN.rated_torque_Nm=0.2"}, {}},
        CorpusDrive{"fixed_mapping.eds", {}, {}},
        CorpusDrive{"fixed_pdo5.eds",
                    {"jointN.rated_torque_Nm=0.2", "jointN.counts_per_rev=65536"},
                    {"--set", "joint1.rated_torque_Nm=0.2", "--set", "joint2.rated_torque_Nm=0.2",
                     "--set", "joint3.rated_torque_Nm=0.2"}}));

TEST(DrivesUsersOwnRefused, ADriveWithoutATorqueModeIsRefusedBeforeTheBus) {
  const std::string file = kSource + "/tests/data/drives/epos2.eds";
  hil::Child fw = start_path1_firmware({"--set", "joint1.eds=" + file});
  EXPECT_EQ(fw.wait(60s).value_or(-1), 2) << fw.err();
  EXPECT_NE(fw.err().find("joint1.eds (" + file +
                          "): no object 0x6071:00 (target torque): the drive cannot take a "
                          "torque command"),
            std::string::npos)
      << fw.err();
}

}  // namespace
