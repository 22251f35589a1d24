#include "delta/can/protocol.hpp"

#include <gtest/gtest.h>

#include <set>

namespace delta::can::protocol {
namespace {

TEST(ProtocolTest, EveryCobIdOnTheBusIsUnique) {
  std::set<std::uint16_t> ids;
  std::size_t count = 0;
  for (const Message& m : kMessages) {
    const int nodes = m.per_node ? kDriveCount : 1;
    for (int k = 0; k < nodes; ++k) {
      const auto id = cob_id(m, static_cast<std::uint8_t>(kFirstDriveNode + k));
      EXPECT_LE(id, 0x7FF) << m.name;
      EXPECT_TRUE(ids.insert(id).second) << m.name << " reuses 0x" << std::hex << id;
      ++count;
    }
  }
  EXPECT_EQ(count, 37u);
  // The log frames are TPDO1..3 of the controller's node 16, the collision
  // frame its TPDO4, its emergency and heartbeat those of node 16 too.
  EXPECT_EQ(kLogA.base_id, 0x180 + kControllerNode);
  EXPECT_EQ(kCollision.base_id, 0x480 + kControllerNode);
  // The arm-encoder log frames are its TPDO5 and TPDO6, which CiA 301 gives
  // no COB-ID: those of TPDO1 and TPDO2 of node 16 + 64.
  EXPECT_EQ(kLogD.base_id, 0x180 + kControllerNode + 64);
  EXPECT_EQ(kLogE.base_id, 0x280 + kControllerNode + 64);
  EXPECT_EQ(kControllerEmcy.base_id, kEmcy.base_id + kControllerNode);
  EXPECT_EQ(kControllerHeartbeat.base_id, kHeartbeat.base_id + kControllerNode);
}

TEST(ProtocolTest, SignalsFitTheirFrameAndDoNotOverlap) {
  for (const Message& m : kMessages) {
    std::uint64_t used = 0;
    for (std::uint8_t i = 0; i < m.signal_count; ++i) {
      const Signal& s = m.signals[i];
      EXPECT_LE(s.start_bit + s.length, 8 * m.dlc) << m.name << "." << s.name;
      for (unsigned b = s.start_bit; b < s.start_bit + s.length; ++b) {
        EXPECT_FALSE((used >> b) & 1u) << m.name << "." << s.name << " overlaps at bit " << b;
        used |= std::uint64_t{1} << b;
      }
    }
  }
}

// The named signals are the table's, by name.
TEST(ProtocolTest, NamedSignalsAreTheTablesByName) {
  EXPECT_EQ(&kTpdo1PositionActual, &kTpdo1.signals[1]);
  EXPECT_STREQ(kTpdo1PositionActual.name, "position_actual");
  EXPECT_EQ(&kLogAStale, &kLogA.signals[3]);
  EXPECT_EQ(&kControllerEmcyCycle, &kControllerEmcy.signals[3]);
  EXPECT_EQ(function_code(cob_id(kTpdo1, 3)), kTpdo1.base_id);
  EXPECT_EQ(node_id(cob_id(kTpdo1, 3)), 3);
}

TEST(ProtocolTest, PackAndUnpackRoundTripWithSignExtension) {
  const Message& log_a = kMessages[9];
  std::array<std::uint8_t, 8> d{};
  pack(d, log_a.signals[0], 32767);    // seq, 15 bits
  pack(d, log_a.signals[1], -3);       // q1, 24-bit signed
  pack(d, log_a.signals[2], 8388607);  // q2 at its maximum
  EXPECT_EQ(unpack(d, log_a.signals[0]), 32767);
  EXPECT_EQ(unpack(d, log_a.signals[3]), 0);  // stale, the top bit of bytes 0-1
  EXPECT_EQ(unpack(d, log_a.signals[1]), -3);
  EXPECT_EQ(unpack(d, log_a.signals[2]), 8388607);
  // Little endian: seq in bytes 0-1, q1 in 2-4.
  EXPECT_EQ(d[0], 0xFF);
  EXPECT_EQ(d[1], 0x7F);
  EXPECT_EQ(d[2], 0xFD);
  EXPECT_EQ(d[4], 0xFF);
  pack(d, log_a.signals[3], 1);
  EXPECT_EQ(d[1], 0xFF);
  EXPECT_EQ(unpack(d, log_a.signals[0]), 32767);
  // Overwriting one signal leaves its neighbours alone.
  pack(d, log_a.signals[1], 0x123456);
  EXPECT_EQ(unpack(d, log_a.signals[0]), 32767);
  EXPECT_EQ(unpack(d, log_a.signals[1]), 0x123456);
  EXPECT_EQ(unpack(d, log_a.signals[2]), 8388607);
  // pack_log: seq modulo 32768 and the stale mark in all three frames.
  const LogPayloads logp = pack_log(32768 + 5, true, {1, 2, 3}, {4, 5, 6});
  for (unsigned i = 0; i < 3; ++i) {
    EXPECT_EQ(unpack(logp.data[i], kMessages[9 + i].signals[0]), 5);
    EXPECT_EQ(unpack(logp.data[i], kMessages[9 + i].signals[3]), 1);
  }
  EXPECT_EQ(unpack(pack_log(7, false, {}, {}).data[2], kMessages[11].signals[3]), 0);
  // pack_arm_log: the same seq and stale mark, the arm angles saturated.
  const ArmLogPayloads arm = pack_arm_log(32768 + 9, true, {-5, 1 << 25, 77});
  EXPECT_EQ(unpack(arm.data[0], kLogDSeq), 9);
  EXPECT_EQ(unpack(arm.data[1], kLogESeq), 9);
  EXPECT_EQ(unpack(arm.data[0], kLogDStale), 1);
  EXPECT_EQ(unpack(arm.data[1], kLogEStale), 1);
  EXPECT_EQ(unpack(arm.data[0], kLogDQa1), -5);
  EXPECT_EQ(unpack(arm.data[0], kLogDQa2), (1 << 23) - 1);
  EXPECT_EQ(unpack(arm.data[1], kLogEQa3), 77);
  EXPECT_EQ(unpack(pack_arm_log(3, false, {}).data[1], kLogEStale), 0);
  const Message& emcy = kMessages[2];
  pack(d, emcy.signals[2], 0xABCDEF0123);  // 40-bit vendor field
  EXPECT_EQ(unpack(d, emcy.signals[2]), 0xABCDEF0123);
  static_assert([] {
    std::array<std::uint8_t, 8> c{};
    pack(c, kMessages[3].signals[1], -123456789);
    return unpack(c, kMessages[3].signals[1]) == -123456789;
  }());
}

TEST(ProtocolTest, WorstCaseFrameLengthsWithBitStuffing) {
  EXPECT_EQ(worst_case_frame_bits(0), 55u);
  EXPECT_EQ(worst_case_frame_bits(4), 95u);
  EXPECT_EQ(worst_case_frame_bits(8), 135u);
  EXPECT_EQ(worst_case_frame_bits(8, true), 160u);
}

TEST(ProtocolTest, BusLoadDecidesTheCycleRate) {
  // SYNC + 3 x (RPDO1 + TPDO1) + the 3 log frames: 55 + 3 * 270 + 405 bits.
  EXPECT_EQ(cycle_bits(false, true), 1270u);
  EXPECT_EQ(cycle_bits(true, true), 1555u);
  constexpr std::uint32_t kMbit = 1000000;
  // 1 kHz does not fit classical CAN at 1 Mbit/s at all...
  EXPECT_GT(bus_load_per_mille(cycle_bits(false, true), 1000, kMbit), 1000u);
  // ...500 Hz fits below 70 % without the velocity PDO (63.5 %), 400 Hz with it (62.2 %).
  EXPECT_EQ(bus_load_per_mille(cycle_bits(false, true), 500, kMbit), 635u);
  EXPECT_GT(bus_load_per_mille(cycle_bits(true, true), 500, kMbit), 700u);
  EXPECT_EQ(bus_load_per_mille(cycle_bits(true, true), 400, kMbit), 622u);
  // The SYNC counter (docs/protocol.md): a byte in the SYNC and three
  // 1-byte TPDO3s, 205 bits; 500 Hz no longer fits, 400 Hz does (59.0 %).
  EXPECT_EQ(cycle_bits(false, true, true), 1475u);
  EXPECT_EQ(cycle_bits(true, true, true), 1760u);
  EXPECT_GT(bus_load_per_mille(cycle_bits(false, true, true), 500, kMbit), 700u);
  EXPECT_EQ(bus_load_per_mille(cycle_bits(false, true, true), 400, kMbit), 590u);
  EXPECT_GT(bus_load_per_mille(cycle_bits(true, true, true), 400, kMbit), 700u);
  EXPECT_EQ(bus_load_per_mille(cycle_bits(true, true, true), 250, kMbit), 440u);
  // Arm-side encoders: a 4-byte TPDO4 per drive, LOG_D (8 bytes) and LOG_E
  // (5 bytes), 285 + 135 + 105 bits; 400 Hz no longer fits, 320 Hz (a
  // period of 3125 us, which divides one second) does, with the velocity
  // PDO too.
  EXPECT_EQ(cycle_bits(false, true, false, true), 1795u);
  EXPECT_GT(bus_load_per_mille(cycle_bits(false, true, false, true), 400, kMbit), 700u);
  EXPECT_EQ(bus_load_per_mille(cycle_bits(false, true, false, true), 320, kMbit), 574u);
  EXPECT_EQ(bus_load_per_mille(cycle_bits(true, true, false, true), 320, kMbit), 665u);
  EXPECT_EQ(bus_load_per_mille(cycle_bits(false, true, false, true), 250, kMbit), 448u);
}

}  // namespace
}  // namespace delta::can::protocol
