// The SocketCAN layer on a real vcan interface (run by hil/vcan-run, which
// provides it natively or in a VM).
#include "delta/can/socketcan.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "vcan_interface.hpp"

namespace delta::can {
namespace {

using namespace std::chrono_literals;
const std::string kIface = hil::vcan_interface();

Frame make(std::uint32_t id, std::initializer_list<std::uint8_t> bytes, bool extended = false) {
  Frame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (auto b : bytes) f.data[i++] = b;
  return f;
}

std::optional<Received> next(Socket& s, std::chrono::milliseconds timeout = 1000ms) {
  if (!s.wait_readable(timeout)) return std::nullopt;
  return s.receive();
}

TEST(SocketCanHilTest, FramesTravelBetweenSocketsWithKernelTimestamps) {
  Socket tx = Socket::open(kIface);
  Socket rx = Socket::open(kIface);
  const auto before = std::chrono::system_clock::now().time_since_epoch();
  ASSERT_EQ(tx.send(make(0x181, {1, 2, 3, 4, 5, 6, 7, 8})), SendResult::kOk);
  ASSERT_EQ(tx.send(make(0x18FF50E5, {0xAA}, true)), SendResult::kOk);
  Frame rtr = make(0x701, {});
  rtr.remote = true;
  ASSERT_EQ(tx.send(rtr), SendResult::kOk);

  auto a = next(rx);
  ASSERT_TRUE(a.has_value());
  EXPECT_EQ(a->frame.id, 0x181u);
  EXPECT_FALSE(a->frame.extended);
  EXPECT_EQ(a->frame.dlc, 8);
  EXPECT_EQ(a->frame.data[7], 8);
  EXPECT_FALSE(a->error.has_value());
  const auto after = std::chrono::system_clock::now().time_since_epoch();
  EXPECT_GE(a->kernel_time, std::chrono::duration_cast<std::chrono::nanoseconds>(before) - 1ms);
  EXPECT_LE(a->kernel_time, std::chrono::duration_cast<std::chrono::nanoseconds>(after) + 1ms);

  auto b = next(rx);
  ASSERT_TRUE(b.has_value());
  EXPECT_TRUE(b->frame.extended);
  EXPECT_EQ(b->frame.id, 0x18FF50E5u);
  EXPECT_EQ(b->frame.data[0], 0xAA);
  EXPECT_GE(b->kernel_time, a->kernel_time);

  auto c = next(rx);
  ASSERT_TRUE(c.has_value());
  EXPECT_TRUE(c->frame.remote);
  EXPECT_EQ(c->frame.id, 0x701u);

  // A socket does not see its own frames unless asked.
  EXPECT_FALSE(tx.receive().has_value());
}

TEST(SocketCanHilTest, FiltersPassOnlyMatchingIds) {
  Socket tx = Socket::open(kIface);
  // TPDO1 of nodes 1..3 (0x181..0x183) and nothing else.
  Socket rx = Socket::open(kIface, {{0x180, 0x7FC, false}});
  for (std::uint32_t id : {0x080u, 0x181u, 0x201u, 0x183u, 0x701u, 0x184u}) {
    ASSERT_EQ(tx.send(make(id, {static_cast<std::uint8_t>(id)})), SendResult::kOk);
  }
  std::vector<std::uint32_t> got;
  while (auto r = next(rx, 200ms)) got.push_back(r->frame.id);
  EXPECT_EQ(got, (std::vector<std::uint32_t>{0x181, 0x183}));
}

TEST(SocketCanHilTest, NonBlockingReceiveAndPollTimeout) {
  Socket rx = Socket::open(kIface);
  EXPECT_FALSE(rx.receive().has_value());
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(rx.wait_readable(50ms));
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 45ms);
}

TEST(SocketCanHilTest, ManyFramesArriveCompleteAndInOrderWhileTheReaderKeepsUp) {
  Socket tx = Socket::open(kIface);
  Socket rx = Socket::open(kIface);
  constexpr int kFrames = 2000;
  int sent = 0, received = 0;
  std::uint16_t expected = 0;
  while (received < kFrames) {
    // Bursts of up to 64 frames ahead of the reader.
    while (sent < kFrames && sent - received < 64) {
      Frame f = make(
          0x280, {static_cast<std::uint8_t>(sent & 0xFF), static_cast<std::uint8_t>(sent >> 8)});
      const SendResult r = tx.send(f);
      if (r == SendResult::kWouldBlock) break;
      ASSERT_EQ(r, SendResult::kOk);
      ++sent;
    }
    auto r = next(rx);
    ASSERT_TRUE(r.has_value()) << "frame " << received << " never arrived";
    const auto seq = static_cast<std::uint16_t>(r->frame.data[0] | (r->frame.data[1] << 8));
    ASSERT_EQ(seq, expected);
    ++expected;
    ++received;
    EXPECT_EQ(r->socket_drops, 0u);
  }
}

TEST(SocketCanHilTest, AReaderThatFallsBehindSeesTheDropCount) {
  // vcan never blocks the sender: 2000 frames at once overflow the reader's
  // socket buffer, and the kernel counts what it dropped.
  Socket tx = Socket::open(kIface);
  Socket rx = Socket::open(kIface);
  for (int i = 0; i < 2000; ++i) ASSERT_EQ(tx.send(make(0x280, {1})), SendResult::kOk);
  std::uint32_t received = 0;
  while (next(rx, 200ms)) ++received;
  EXPECT_LT(received, 2000u);
  // The drops show on the next frame that gets through.
  ASSERT_EQ(tx.send(make(0x280, {2})), SendResult::kOk);
  const auto after = next(rx);
  ASSERT_TRUE(after.has_value());
  EXPECT_EQ(received + after->socket_drops, 2000u);
}

TEST(SocketCanHilTest, MissingInterfaceIsNamed) {
  try {
    Socket::open("vcan9");
    FAIL();
  } catch (const CanError& e) {
    EXPECT_STREQ(e.what(), "CAN interface 'vcan9' does not exist (ip link show vcan9)");
  }
}

}  // namespace
}  // namespace delta::can
