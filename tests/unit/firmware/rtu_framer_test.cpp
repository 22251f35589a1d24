// Modbus RTU framing (fw_linux/rtu_framer.hpp): by the function's length
// where the function code gives it, else by the line's silence.
#include "fw_linux/rtu_framer.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <vector>

namespace {

using fw_linux::RtuFramer;
using Next = RtuFramer::Next;

std::vector<std::uint8_t> with_crc(std::vector<std::uint8_t> frame) {
  const std::uint16_t crc = fw_linux::modbus_crc16(frame.data(), frame.size());
  frame.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  frame.push_back(static_cast<std::uint8_t>(crc >> 8));
  return frame;
}

void add(RtuFramer& framer, const std::vector<std::uint8_t>& bytes) {
  ASSERT_LE(bytes.size(), framer.space_left());
  std::memcpy(framer.space(), bytes.data(), bytes.size());
  framer.added(bytes.size());
}

TEST(RtuFramerTest, TheCrcIsModbussCheckValue) {
  const std::uint8_t digits[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  EXPECT_EQ(fw_linux::modbus_crc16(digits, sizeof digits), 0x4B37);  // CRC-16/MODBUS
}

TEST(RtuFramerTest, TheFrameGapIsThreeAndAHalfCharactersOrTheFixedValueAbove19200) {
  EXPECT_EQ(fw_linux::rtu_frame_gap_us(9600), 4011u);  // 3.5 * 11 bits / 9600 baud, up
  EXPECT_EQ(fw_linux::rtu_frame_gap_us(19200), 2006u);
  EXPECT_EQ(fw_linux::rtu_frame_gap_us(19201), 1750u);
  EXPECT_EQ(fw_linux::rtu_frame_gap_us(115200), 1750u);
}

TEST(RtuFramerTest, AKnownRequestIsWholeAtItsLengthByteByByte) {
  const auto read = with_crc({7, 0x04, 0, 3, 0, 2});
  RtuFramer framer;
  std::size_t length = 0;
  EXPECT_EQ(framer.next(length), Next::kNothing);
  for (std::size_t i = 0; i + 1 < read.size(); ++i) {
    add(framer, {read[i]});
    EXPECT_EQ(framer.next(length), Next::kNeedMore) << "after byte " << i;
  }
  add(framer, {read.back()});
  ASSERT_EQ(framer.next(length), Next::kFrame);
  EXPECT_EQ(length, 8u);
}

TEST(RtuFramerTest, WriteMultipleTakesItsLengthFromTheByteCount) {
  const auto write = with_crc({7, 0x10, 0, 0, 0, 2, 4, 0, 1, 0, 2});
  RtuFramer framer;
  std::size_t length = 0;
  add(framer, {write.begin(), write.begin() + 6});
  EXPECT_EQ(framer.next(length), Next::kNeedMore);
  add(framer, {write.begin() + 6, write.end() - 1});
  EXPECT_EQ(framer.next(length), Next::kNeedMore);
  add(framer, {write.back()});
  ASSERT_EQ(framer.next(length), Next::kFrame);
  EXPECT_EQ(length, 13u);
}

TEST(RtuFramerTest, TwoRequestsInOneReadAreTwoFrames) {
  auto both = with_crc({7, 0x06, 0, 1, 0, 5});
  const auto second = with_crc({7, 0x03, 0, 0, 0, 4});
  both.insert(both.end(), second.begin(), second.end());
  RtuFramer framer;
  add(framer, both);
  std::size_t length = 0;
  ASSERT_EQ(framer.next(length), Next::kFrame);
  ASSERT_EQ(length, 8u);
  framer.consume(length);
  ASSERT_EQ(framer.next(length), Next::kFrame);
  EXPECT_EQ(framer.data()[1], 0x03);
  framer.consume(length);
  EXPECT_EQ(framer.next(length), Next::kNothing);
}

// Diagnostics (0x08), a code of 0x80 or more, and 0x2B with its odd
// payload: the function does not say the length, so the silence ends the
// frame, whole when its CRC holds over all of it.
TEST(RtuFramerTest, AnUnknownFunctionEndsAtTheSilence) {
  for (const auto& frame : {with_crc({7, 0x08, 0, 0, 0xA5, 0x37}), with_crc({7, 0x83, 0, 0, 0, 1}),
                            with_crc({7, 0x2B, 0x0E, 0x01, 0x00})}) {
    RtuFramer framer;
    add(framer, frame);
    std::size_t length = 0;
    EXPECT_EQ(framer.next(length), Next::kAtSilence) << int{frame[1]};
    ASSERT_TRUE(framer.whole_at_silence(length));
    EXPECT_EQ(length, frame.size());
  }
}

TEST(RtuFramerTest, ABadCrcOrAFragmentIsNoFrameAtTheSilence) {
  auto bad = with_crc({7, 0x08, 0, 0, 0xA5, 0x37});
  bad.back() ^= 0x01;
  RtuFramer framer;
  add(framer, bad);
  std::size_t length = 0;
  EXPECT_FALSE(framer.whole_at_silence(length));
  framer.clear();
  add(framer, {7, 0x08, 0});
  EXPECT_FALSE(framer.whole_at_silence(length));
}

// On a multi-drop line another unit's reply passes by: a reply to 04 is
// longer than the request, so the request's length finds no good CRC; the
// silence then ends the reply, whole.
TEST(RtuFramerTest, AnotherUnitsReplyEndsAtTheSilence) {
  const auto reply = with_crc({9, 0x04, 4, 0, 1, 0, 2});
  RtuFramer framer;
  add(framer, reply);
  std::size_t length = 0;
  EXPECT_EQ(framer.next(length), Next::kAtSilence);
  ASSERT_TRUE(framer.whole_at_silence(length));
  EXPECT_EQ(length, 9u);
}

TEST(RtuFramerTest, AByteCountBeyondTheLargestFrameWaitsForTheSilence) {
  RtuFramer framer;
  add(framer, {7, 0x10, 0, 0, 0, 127, 254});  // 9 + 254 bytes > 256
  std::size_t length = 0;
  EXPECT_EQ(framer.next(length), Next::kAtSilence);
}

}  // namespace
