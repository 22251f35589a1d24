// libFuzzer harness: the Modbus server's request handling (RegisterBank),
// fed whole TCP ADUs as the framing passes them on: reads, single and
// multiple writes (the custom trajectory block's 32-bit registers, the
// checks a selection runs), commands, and anything else. An input is one
// client's requests in order, each as long as its MBAP header's length
// says (the last takes what is left), to a server of its own: an input's
// outcome does not depend on the inputs before it. Its contract: every
// request is answered (a reply or an exception) or dropped for bad
// framing, the holding table reads back after each, and the custom block
// always holds a trajectory the block reader can take.
#include <fcntl.h>
#include <modbus/modbus.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "delta/custom_trajectory_block.hpp"
#include "delta/modbus/register_map.hpp"
#include "fw_linux/control_panel.hpp"
#include "fw_linux/modbus_server.hpp"

namespace {

namespace mb = delta::modbus;

// The replies go into a socket pair that is drained after each request;
// the pair and the libmodbus context serve the whole run.
struct Wire {
  Wire() {
    if (socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) std::abort();
    fcntl(fds[1], F_SETFL, O_NONBLOCK);
    ctx = modbus_new_tcp("127.0.0.1", 1502);
    if (ctx == nullptr || modbus_set_socket(ctx, fds[0]) != 0) std::abort();
  }
  void drain() {
    std::uint8_t buf[512];
    while (read(fds[1], buf, sizeof buf) > 0) {
    }
  }
  int fds[2]{-1, -1};
  modbus_t* ctx{nullptr};
};

fw_linux::PortConfig config() {
  fw_linux::PortConfig c;
  c.modbus.command_timeout_ms = 0;  // no control loop takes commands here: no wait for one
  // A 50 Hz cycle: a trajectory check walks a tenth of the ticks it walks
  // at 500 Hz, and the seed too long at 500 Hz (long_custom_trajectory,
  // 28 000 s) is still too long to walk.
  c.period_us = 20000;
  return c;
}

std::vector<std::uint8_t> read_holding_request() {
  // MBAP (transaction 1, protocol 0, length 6, unit 1), then 03 0 count.
  return {0, 1, 0, 0, 0, 6, 1, 3, 0, 0, 0, static_cast<std::uint8_t>(mb::kHoldingCount)};
}

void serve(Wire& wire, fw_linux::RegisterBank& bank, const std::uint8_t* adu, std::size_t size) {
  std::vector<std::uint8_t> request(adu, adu + size);
  bank.answer(wire.ctx, request.data(), static_cast<int>(request.size()));
  wire.drain();
  std::vector<std::uint8_t> read = read_holding_request();
  if (bank.answer(wire.ctx, read.data(), static_cast<int>(read.size())) !=
      fw_linux::RegisterBank::Outcome::kReplied) {
    std::abort();  // the holding table must always read back
  }
  // The reply: MBAP (7), function, byte count, then the registers.
  std::uint8_t reply[512];
  const ssize_t n = ::read(wire.fds[1], reply, sizeof reply);
  if (n != 9 + 2 * mb::kHoldingCount) std::abort();
  std::vector<std::uint16_t> block(mb::kCustomCount);
  for (unsigned i = 0; i < mb::kCustomCount; ++i) {
    const unsigned at = 9 + 2 * (mb::kCustomFirst + i);
    block[i] = static_cast<std::uint16_t>(reply[at] << 8 | reply[at + 1]);
  }
  const delta::BlendedFourierTrajectory t = delta::custom_trajectory_of(block.data());
  if (t.fourier.a_rad_s[0].size() > mb::kCustomMaxHarmonics) std::abort();
  wire.drain();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Wire wire;
  static const fw_linux::PortConfig c = config();
  fw_linux::ControlPanel panel;
  fw_linux::RegisterBank bank(c, panel, fw_linux::ProgramFacts{{1, 2, 3}, {}});
  for (std::size_t at = 0; at < size;) {
    std::size_t n = size - at;
    if (n >= 6) n = std::min<std::size_t>(n, 6 + (data[at + 4] << 8 | data[at + 5]));
    if (n > MODBUS_TCP_MAX_ADU_LENGTH) break;  // the framing never passes more
    serve(wire, bank, data + at, n);
    at += n;
  }
  return 0;
}
