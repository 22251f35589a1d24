// SocketCAN pieces that need no CAN bus: error-frame decoding and the
// messages for a missing interface or a kernel without CAN.
#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>

#include "delta/can/socketcan.hpp"

namespace delta::can {
namespace {

TEST(SocketCanUnitTest, ErrorFramesDecodeIntoFaults) {
  std::array<std::uint8_t, 8> data{};
  BusError e = decode_error_frame(CAN_ERR_BUSOFF, data);
  EXPECT_TRUE(e.bus_off);
  EXPECT_FALSE(e.error_passive);
  data[1] = CAN_ERR_CRTL_TX_PASSIVE;
  e = decode_error_frame(CAN_ERR_CRTL, data);
  EXPECT_FALSE(e.bus_off);
  EXPECT_TRUE(e.error_passive);
  data[1] = CAN_ERR_CRTL_RX_WARNING;
  e = decode_error_frame(CAN_ERR_CRTL | CAN_ERR_ACK, data);
  EXPECT_TRUE(e.warning);
  EXPECT_TRUE(e.no_ack);
  EXPECT_EQ(e.raw_class, static_cast<std::uint32_t>(CAN_ERR_CRTL | CAN_ERR_ACK));
}

TEST(SocketCanUnitTest, OpeningANonexistentInterfaceSaysWhatIsWrong) {
  // Either this kernel has no CAN at all (as on the CI machines), or the
  // interface is missing: both are said plainly.
  try {
    Socket::open("nosuchcan7");
    FAIL() << "expected CanError";
  } catch (const CanError& e) {
    const std::string m = e.what();
    const bool no_can = m.find("this kernel has no CAN support") != std::string::npos &&
                        m.find("hil/vcan-run") != std::string::npos;
    const bool missing = m == "CAN interface 'nosuchcan7' does not exist (ip link show nosuchcan7)";
    EXPECT_TRUE(no_can || missing) << m;
  }
  EXPECT_THROW(Socket::open(""), CanError);
  EXPECT_THROW(Socket::open("an-interface-name-too-long"), CanError);
}

TEST(SocketCanUnitTest, FramesAreDescribedForMessages) {
  Frame f;
  f.id = 0x181;
  f.dlc = 3;
  f.data = {0x01, 0xAB, 0xFF};
  EXPECT_EQ(describe(f), "0x181 [3] 01 AB FF");
  f.extended = true;
  f.id = 0x18FF50E5;
  f.dlc = 0;
  EXPECT_EQ(describe(f), "0x18FF50E5 [0]");
}

}  // namespace
}  // namespace delta::can
