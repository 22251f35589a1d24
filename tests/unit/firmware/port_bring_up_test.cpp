// The in-process bring-up against the drives' identity (0x1018) and the
// EDS files that describe them: drives of the right product come up, of
// another product or serial are refused naming node, object and values.
#include <gtest/gtest.h>

#include <string>

#include "emu/emulator.hpp"
#include "fw/controller.hpp"
#include "fw_linux/canopen_master.hpp"
#include "fw_linux/config.hpp"
#include "in_process_rig.hpp"
#include "port_test_support.hpp"

namespace fw_linux {
namespace {

using port_test::bring_up;
using port_test::write_temp;

TEST(InProcessPortTest, DrivesWithTheIdentityOfTheirEdsComeUp) {
  PortConfig c = Rig::config();
  for (unsigned j = 0; j < 3; ++j) {
    c.joints[j].identity.vendor_id = emu::kEmulatorVendorId;
    c.joints[j].identity.product_code = emu::kEmulatorProductCode;
    c.joints[j].identity.revision = emu::kEmulatorRevision | 0x0007;  // another minor revision
    c.joints[j].identity.serial = 0x00010001u + j;
  }
  Rig rig(c, {});
  EXPECT_TRUE(bring_up(rig)) << rig.master.last_problem();
}

// The second product (docs/eds/delta_drive_emu_b.eds): configured with its
// EDS the bring-up takes it; configured with the first product's, it
// refuses it.
TEST(InProcessPortTest, TheBringUpFollowsTheEdsOfTheDriveOnTheBus) {
  const std::string b = DELTA_EDS_DIR "/delta_drive_emu_b.eds";
  PortConfig c = read_port_config(write_temp("mode = lockstep\njoint1.eds = " + b +
                                             "\njoint2.eds = " + b + "\njoint3.eds = " + b + "\n"));
  Rig rig(c, {});
  rig.bus.emulator_.set_product(emu::product_of(delta::canopen::read_eds(b)));
  EXPECT_TRUE(bring_up(rig)) << rig.master.last_problem();
  // Its default TPDO1 is 6 bytes; the bring-up's mapping makes it the 8 of
  // docs/protocol.md, and the cyclic exchange runs without a problem.
  for (int n = 0; n < 20; ++n) rig.cycle();
  EXPECT_EQ(rig.controller.state(), fw::State::kReady);
  EXPECT_EQ(rig.master.last_problem(), "");
  const std::string a = DELTA_EDS_DIR "/delta_drive_emu.eds";
  c = read_port_config(write_temp("mode = lockstep\njoint1.eds = " + a + "\n"));
  Rig wrong(c, {});
  wrong.bus.emulator_.set_product(emu::product_of(delta::canopen::read_eds(b)));
  for (int n = 0; n < 50 && wrong.controller.state() != fw::State::kFault; ++n) wrong.cycle();
  EXPECT_EQ(wrong.master.last_problem(),
            "node 1, 0x1018:02: product code 0x00000403; joint1.eds = " + a +
                " expects 0x00000402: is this the drive the configuration describes?");
}

TEST(InProcessPortTest, ADriveOfAnotherProductOrSerialIsRefusedNamingNodeObjectAndBothValues) {
  PortConfig c = Rig::config();
  c.joints[1].identity.product_code = 0x00000403;
  c.joints[1].identity.source = "joint2.eds = other.eds";
  Rig rig(c, {});
  for (int n = 0; n < 50 && rig.controller.state() != fw::State::kFault; ++n) rig.cycle();
  EXPECT_EQ(rig.controller.fault(), fw::Fault::kDriveConfigFailed);
  EXPECT_EQ(
      rig.master.last_problem(),
      "node 2, 0x1018:02: product code 0x00000402; joint2.eds = other.eds expects 0x00000403: "
      "is this the drive the configuration describes?");
  c = Rig::config();
  c.joints[2].identity.serial = 12;
  c.joints[2].identity.revision = 0x00020000;
  c.joints[2].identity.source = "joint3.serial";
  Rig second(c, {});
  for (int n = 0; n < 50 && second.controller.state() != fw::State::kFault; ++n) second.cycle();
  EXPECT_NE(
      second.master.last_problem().find("node 3, 0x1018:03: revision number 0x00010000; "
                                        "joint3.serial expects 0x00020000 (major revision 2)"),
      std::string::npos)
      << second.master.last_problem();
}

TEST(InProcessPortTest, AWrongValueInTheBringUpFaultsWithItsCauseAndIsNotRetried) {
  // The configuration expects another encoder than the drives have.
  PortConfig c = Rig::config();
  c.joints[1].model.counts_per_rev = 4096;
  Rig rig(c, {});
  for (int n = 0; n < 50 && rig.controller.state() != fw::State::kFault; ++n) rig.cycle();
  EXPECT_EQ(rig.controller.fault(), fw::Fault::kDriveConfigFailed);
  EXPECT_NE(rig.master.last_problem().find("node 2, 0x608F:01"), std::string::npos)
      << rig.master.last_problem();
  EXPECT_NE(rig.master.last_problem().find("the configuration says 4096 (joint2.counts_per_rev)"),
            std::string::npos)
      << rig.master.last_problem();
}

}  // namespace
}  // namespace fw_linux
