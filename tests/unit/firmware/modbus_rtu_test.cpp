// The Modbus RTU server on a pseudo-terminal pair (posix_openpt): frames
// written by hand, and mbpoll as the master.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>
#include <thread>
#include <vector>

#include "modbus_fixture.hpp"

namespace fw_linux {
namespace {

namespace mb = delta::modbus;
using modbus_test::kFacts;
using modbus_test::LoopThread;
using std::chrono::milliseconds;
using std::chrono::steady_clock;

// --- RTU on a pseudo-terminal ---

std::uint16_t crc16(const std::vector<std::uint8_t>& d) {
  std::uint16_t crc = 0xFFFF;
  for (std::uint8_t b : d) {
    crc ^= b;
    for (int i = 0; i < 8; ++i)
      crc = (crc & 1) ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001) : crc >> 1;
  }
  return crc;
}

std::vector<std::uint8_t> rtu_frame(std::vector<std::uint8_t> pdu) {
  const std::uint16_t crc = crc16(pdu);
  pdu.push_back(static_cast<std::uint8_t>(crc & 0xFF));
  pdu.push_back(static_cast<std::uint8_t>(crc >> 8));
  return pdu;
}

// Reads `n` bytes or until `ms` pass (for "no answer": well over the
// server's 100 ms byte timeout).
std::vector<std::uint8_t> read_bytes(int fd, std::size_t n, int ms = 3000) {
  std::vector<std::uint8_t> got;
  const auto deadline = steady_clock::now() + milliseconds(ms);
  while (got.size() < n && steady_clock::now() < deadline) {
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    std::uint8_t buf[300];
    const ssize_t r = read(fd, buf, sizeof buf);
    if (r > 0) got.insert(got.end(), buf, buf + r);
  }
  return got;
}

// A pseudo-terminal as the serial line: the test writes and reads at the
// master side; the server opens the other side as its device.
class SerialLine {
 public:
  SerialLine() : master_(posix_openpt(O_RDWR | O_NOCTTY | O_CLOEXEC)) {
    if (master_ < 0 || grantpt(master_) != 0 || unlockpt(master_) != 0) {
      ADD_FAILURE() << "no pseudo-terminal: " << std::strerror(errno);
      return;
    }
    termios t{};
    tcgetattr(master_, &t);
    cfmakeraw(&t);
    tcsetattr(master_, TCSANOW, &t);
  }
  ~SerialLine() { close(master_); }
  SerialLine(const SerialLine&) = delete;
  SerialLine& operator=(const SerialLine&) = delete;
  int fd() const { return master_; }
  // The server's configuration: unit 7, 115200 baud, even parity, a byte
  // timeout of 100 ms.
  PortConfig config() const {
    PortConfig c = Rig::config();
    c.modbus.rtu_device = ptsname(master_);
    c.modbus.rtu_baud = 115200;
    c.modbus.rtu_parity = 'E';
    c.modbus.rtu_unit_id = 7;
    c.modbus.byte_timeout_ms = 100;
    return c;
  }
  void send(const std::vector<std::uint8_t>& bytes) const {
    ASSERT_EQ(write(master_, bytes.data(), bytes.size()), static_cast<ssize_t>(bytes.size()));
  }

 private:
  int master_;
};

TEST(ModbusRtuTest, AnswersFramesOnAPseudoTerminalAndIgnoresBadOnes) {
  SerialLine line;
  const int master = line.fd();
  PortConfig c = line.config();
  ControlPanel panel;
  {
    ModbusServer server(c, panel, kFacts);
    LoopThread loop(panel);
    // Read input registers 3..4 (protocol version, state) from unit 7.
    const auto read_req = rtu_frame({7, 0x04, 0, 3, 0, 2});
    // A frame with a bad CRC, and one for another unit: no answer to either.
    auto bad = read_req;
    bad.back() ^= 0x55;
    ASSERT_EQ(write(master, bad.data(), bad.size()), static_cast<ssize_t>(bad.size()));
    const auto other = rtu_frame({9, 0x04, 0, 3, 0, 2});
    // A gap longer than the byte timeout, so that the next frame starts clean.
    EXPECT_TRUE(read_bytes(master, 1, 500).empty()) << "no answer to a bad CRC";
    ASSERT_EQ(write(master, other.data(), other.size()), static_cast<ssize_t>(other.size()));
    EXPECT_TRUE(read_bytes(master, 1, 500).empty()) << "no answer for another unit";
    // On a multi-drop line unit 9 answers; the server lets that pass too.
    const auto other_reply = rtu_frame({9, 0x04, 4, 0, 1, 0, 2});
    ASSERT_EQ(write(master, other_reply.data(), other_reply.size()),
              static_cast<ssize_t>(other_reply.size()));
    EXPECT_TRUE(read_bytes(master, 1, 500).empty()) << "no answer to unit 9's reply";

    ASSERT_EQ(write(master, read_req.data(), read_req.size()),
              static_cast<ssize_t>(read_req.size()));
    const auto got = read_bytes(master, 9);
    ASSERT_EQ(got.size(), 9u);
    EXPECT_EQ(got[0], 7);
    EXPECT_EQ(got[1], 0x04);
    EXPECT_EQ(got[2], 4);
    EXPECT_EQ((got[3] << 8) | got[4], mb::kMapVersion);
    EXPECT_LE((got[5] << 8) | got[6], static_cast<int>(fw::State::kFault));
    EXPECT_EQ(crc16({got.begin(), got.end() - 2}), got[7] | (got[8] << 8));

    // An out-of-range write: exception 03 in an RTU frame.
    const auto wr = rtu_frame({7, 0x06, 0, 0, 0, 9});
    ASSERT_EQ(write(master, wr.data(), wr.size()), static_cast<ssize_t>(wr.size()));
    const auto ex = read_bytes(master, 5);
    ASSERT_EQ(ex.size(), 5u);
    EXPECT_EQ(ex[1], 0x86);
    EXPECT_EQ(ex[2], 0x03);
    EXPECT_GE(server.stats().receive_errors, 1u);
  }
}

// Functions the server does not serve get exception 01 on the serial line
// too, with their own function code, whatever their payload, and the line
// stays in step (#19: with libmodbus's framing, which takes an unknown
// function's frame to end after its code, diagnostics 0x08 got no answer
// at all). A known request that arrives in two pieces 50 ms apart (a USB
// adapter's latency), within the byte timeout, is still one request.
TEST(ModbusRtuTest, UnservedFunctionsGetExceptionOneAndTheLineStaysInStep) {
  SerialLine line;
  ControlPanel panel;
  ModbusServer server(line.config(), panel, kFacts);
  LoopThread loop(panel);
  const std::vector<std::pair<std::vector<std::uint8_t>, std::uint8_t>> unserved = {
      {{7, 0x08, 0, 0, 0xA5, 0x37}, 0x88},  // diagnostics: return query data
      {{7, 0x83, 0, 0, 0, 1}, 0x83},        // no such function: the code as sent
      {{7, 0x2B, 0x0E, 0x01, 0x00}, 0xAB},  // read device identification
      {{7, 0x01, 0, 0, 0, 8}, 0x81},        // read coils: a known layout, not served
  };
  for (const auto& [request, function] : unserved) {
    line.send(rtu_frame(request));
    EXPECT_EQ(read_bytes(line.fd(), 5), rtu_frame({7, function, 0x01})) << int{request[1]};
  }
  const auto read = rtu_frame({7, 0x04, 0, 3, 0, 1});
  line.send({read.begin(), read.begin() + 3});
  std::this_thread::sleep_for(milliseconds(50));  // the adapter's latency, not synchronisation
  line.send({read.begin() + 3, read.end()});
  const auto got = read_bytes(line.fd(), 7);
  ASSERT_EQ(got.size(), 7u);
  EXPECT_EQ(got[1], 0x04);
  EXPECT_EQ((got[3] << 8) | got[4], mb::kMapVersion);
  EXPECT_EQ(server.stats().exceptions, unserved.size());
  EXPECT_EQ(server.stats().receive_errors, 0u);
}

// mbpoll (Debian's package; libmodbus inside, none of our code) as the
// master on a second pseudo-terminal, bridged byte for byte to the
// server's line by a thread: it reads the map version and the state, and
// its report-slave-id request (0x11, which the server does not serve) is
// told "Illegal function" (exception 01).
class LineBridge {
 public:
  LineBridge(int a, int b) : thread_([this, a, b] { run(a, b); }) {}
  ~LineBridge() {
    stop_.store(true);
    thread_.join();
  }
  LineBridge(const LineBridge&) = delete;
  LineBridge& operator=(const LineBridge&) = delete;

 private:
  void run(int a, int b) {
    while (!stop_.load()) {
      pollfd fds[2] = {{a, POLLIN, 0}, {b, POLLIN, 0}};
      if (poll(fds, 2, 20) <= 0) continue;
      for (int k = 0; k < 2; ++k) {
        if ((fds[k].revents & POLLIN) == 0) continue;
        std::uint8_t buf[256];
        const ssize_t n = read(fds[k].fd, buf, sizeof buf);
        if (n > 0 && write(fds[1 - k].fd, buf, static_cast<std::size_t>(n)) != n) return;
      }
    }
  }
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

std::string run_mbpoll(const std::string& args) {
  std::string out;
  FILE* p = popen(("/usr/bin/mbpoll " + args + " 2>&1").c_str(), "r");
  if (p == nullptr) return "popen failed";
  char buf[256];
  while (fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int status = pclose(p);
  return out + "exit " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + "\n";
}

TEST(ModbusRtuTest, MbpollReadsRegistersAndIsToldWhatIsNotServed) {
  ASSERT_EQ(access("/usr/bin/mbpoll", X_OK), 0) << "mbpoll is not installed (./setup.sh)";
  SerialLine line;
  SerialLine client;
  ControlPanel panel;
  ModbusServer server(line.config(), panel, kFacts);
  LoopThread loop(panel);
  LineBridge bridge(line.fd(), client.fd());
  const std::string device = ptsname(client.fd());
  // Input registers 3 and 4 (PDU addresses): the map version and the state.
  const std::string read =
      run_mbpoll("-m rtu -a 7 -b 115200 -P even -t 3 -0 -r 3 -c 2 -1 -o 2 " + device);
  EXPECT_NE(read.find("[3]: \t" + std::to_string(mb::kMapVersion)), std::string::npos) << read;
  EXPECT_NE(read.find("exit 0"), std::string::npos) << read;
  const std::string report = run_mbpoll("-m rtu -a 7 -b 115200 -P even -u -1 -o 2 " + device);
  EXPECT_NE(report.find("Illegal function"), std::string::npos) << report;
  EXPECT_EQ(server.stats().receive_errors, 0u);
}

}  // namespace
}  // namespace fw_linux
