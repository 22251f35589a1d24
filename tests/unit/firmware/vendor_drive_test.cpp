// The controller with drives that behave as vendors' EDS files describe
// them (the emulator with use_eds(), tests/data/drives/), in one process:
// each drive the plan accepts comes up by its plan and runs an
// excitation; the SDO transfers and the cycles the bring-up takes are
// printed for the record.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "../../support/scratch_directory.hpp"
#include "delta/canopen/eds.hpp"
#include "fw_linux/drive_plan.hpp"
#include "fw_linux/trajectories.hpp"
#include "in_process_rig.hpp"

namespace fw_linux {
namespace {

struct VendorDrive {
  const char* file;
  const char* keys;  // each joint's, with N for its number
  emu::TorqueUnit unit;
  std::int8_t mode;
  Feedback feedback;
};

std::ostream& operator<<(std::ostream& os, const VendorDrive& d) {
  return os << d.file;
}

// The configuration file of a controller with three such drives.
std::string vendor_config_file(const VendorDrive& v) {
  std::string text = "mode = lockstep\n";
  for (char n : {'1', '2', '3'}) {
    text += std::string("jointN.eds = ") + DELTA_DRIVES_DIR + "/" + v.file + "\n" + v.keys;
    for (std::size_t at; (at = text.find("jointN")) != std::string::npos;) text[at + 5] = n;
  }
  const std::string path = testsupport::process_scratch("vendor_drive_test").file("drive.conf");
  std::ofstream(path) << text;
  return path;
}

PortConfig vendor_config(const VendorDrive& v) {
  return read_port_config(vendor_config_file(v));
}

class VendorDriveTest : public ::testing::TestWithParam<VendorDrive> {};

TEST_P(VendorDriveTest, ComesUpByItsPlanAndRunsAnExcitation) {
  const VendorDrive& v = GetParam();
  const PortConfig c = vendor_config(v);
  const DrivePlans plans = plan_drives(c);
  ASSERT_TRUE(plans.problems.empty()) << plans.problems.front();
  EXPECT_EQ(plans.drives[0].mode, v.mode);
  EXPECT_EQ(plans.drives[0].feedback, v.feedback);
  emu::EmulatorConfig ec;
  ec.torque_unit = v.unit;
  Rig rig(c, ec);
  const std::string eds_path = std::string(DELTA_DRIVES_DIR) + "/" + v.file;
  const std::size_t emulated = rig.bus.emulator_.use_eds(delta::canopen::read_eds(eds_path));
  EXPECT_GT(emulated, 20u);
  // The drives as the user commissioned them: the controller's own file
  // (delta_drive_emu --config).
  emu::CommissionedDrives commissioned;
  commissioned.read_config(vendor_config_file(v));
  rig.bus.emulator_.commission(commissioned);
  std::size_t sdo_requests = 0;
  int cycles = 0;
  for (; cycles < 200 && rig.controller.state() != fw::State::kReady; ++cycles) {
    rig.bus.sent_.clear();
    rig.cycle();
    for (const auto& f : rig.bus.sent_) sdo_requests += (f.id & 0x780) == 0x600;
  }
  ASSERT_EQ(rig.controller.state(), fw::State::kReady) << rig.master.last_problem();
  std::cout << "[ bring-up ] " << v.file << ": " << plans.drives[0].actions.size()
            << " SDO transfers a drive, " << sdo_requests << " SDO requests on the bus, " << cycles
            << " cycles\n";
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_EQ(rig.bus.emulator_.tpdo_transmission(j, 1), 1) << "TPDO1 on every SYNC";
  }
  const auto traj = named_trajectory("path2", Rig::config());
  ASSERT_TRUE(traj.has_value());
  ASSERT_TRUE(rig.controller.start(*traj).accepted);
  double worst_error = 0;
  double worst_current = 0;
  double largest_current = 0;
  for (int i = 0; i < 20000 && (i == 0 || rig.controller.state() != fw::State::kReady); ++i) {
    rig.cycle();
    ASSERT_NE(rig.controller.state(), fw::State::kFault)
        << fw::fault_name(rig.controller.fault()) << ": " << rig.master.last_problem();
    for (unsigned j = 0; rig.controller.run_tick() > 1 && j < 3; ++j) {
      const double ref = std::ldexp(rig.controller.reference().q_rad[j].raw(), -28);
      worst_error = std::max(worst_error, std::fabs(ref - rig.bus.emulator_.q_rad()[j]));
    }
    // The feedback (0x6078 or 0x6077, in its unit) is the drive's current.
    std::array<fw::DriveFeedback, 3> fb{};
    rig.master.read_feedback(fb);
    for (unsigned j = 0; rig.controller.run_tick() > 1 && j < 3; ++j) {
      const double measured_A = std::ldexp(fb[j].current_A.raw(), -19);
      worst_current =
          std::max(worst_current, std::fabs(measured_A - rig.bus.emulator_.current_A(j)));
      largest_current = std::max(largest_current, std::fabs(measured_A));
    }
  }
  EXPECT_EQ(rig.controller.state(), fw::State::kReady);
  EXPECT_LT(worst_error, 0.03) << "tracking through the bus";
  EXPECT_LT(worst_current, 0.03) << "the feedback is the drive's current";
  EXPECT_GT(largest_current, 0.1) << "the excitation moved the motors";
  EXPECT_EQ(rig.master.last_problem(), "");
}

INSTANTIATE_TEST_SUITE_P(
    Corpus, VendorDriveTest,
    ::testing::Values(
        // A user's motors, not the emulated one's (0.2 N m, 2 A, 131072
        // counts): each drive is commissioned with the same values.
        VendorDrive{"epos4.eds", "jointN.rated_torque_Nm = 0.5\njointN.counts_per_rev = 4096\n",
                    emu::TorqueUnit::kPerMille, 10, Feedback::kTorque},
        VendorDrive{"tmcm_bldc.eds", "jointN.torque_unit = mA\njointN.rated_torque_Nm = 0.35\n",
                    emu::TorqueUnit::kMilliamp, 4, Feedback::kTorque},
        VendorDrive{"ipos.eds", "jointN.rated_current_A = 3.2\njointN.rated_torque_Nm = 0.32\n",
                    emu::TorqueUnit::kPerMille, 10, Feedback::kCurrent},
        VendorDrive{"fixed_mapping.eds", "", emu::TorqueUnit::kPerMille, 10, Feedback::kTorque},
        // Target torque and torque actual value only in the fixed RPDO5 and
        // TPDO5: the sample comes in two TPDOs (TPDO5 and TPDO1).
        VendorDrive{"fixed_pdo5.eds",
                    "jointN.rated_torque_Nm = 0.5\njointN.counts_per_rev = 65536\n",
                    emu::TorqueUnit::kPerMille, 10, Feedback::kTorque}));

// A configured value that the drive contradicts fails the bring-up, naming
// both: the iPOS-like drive reports 2000 mA (0x6075), configured 3 A.
TEST(VendorDriveRefusalTest, ARatedValueTheDriveContradictsIsNamed) {
  const PortConfig c =
      vendor_config({"ipos.eds", "jointN.rated_current_A = 3\njointN.rated_torque_Nm = 0.3\n",
                     emu::TorqueUnit::kPerMille, 10, Feedback::kCurrent});
  Rig rig(c, {});
  rig.bus.emulator_.use_eds(delta::canopen::read_eds(DELTA_DRIVES_DIR "/ipos.eds"));
  for (int n = 0; n < 50 && rig.controller.state() != fw::State::kFault; ++n) rig.cycle();
  EXPECT_EQ(rig.master.last_problem(),
            "node 1, 0x6075:00: the drive's motor rated current is 2000 mA; "
            "joint1.rated_current_A says 3000 mA: which is the motor's?");
}

}  // namespace
}  // namespace fw_linux
