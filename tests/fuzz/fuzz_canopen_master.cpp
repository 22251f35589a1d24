// libFuzzer harness: the controller (core, CANopen master, its own node
// 16) with the emulated drives behind it, in one process (the unit tests'
// rig), and any frames injected between the cycles: to the master as if
// from a drive, to the drives as if from the controller, to node 16 as if
// from a tool. Nothing may crash or touch memory it does not own (ASan,
// UBSan), the controller's state and fault stay among the named ones, and
// every problem the master records can be put into words; with and without
// the SYNC counter.
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "in_process_rig.hpp"

namespace {

delta::can::Frame frame_from(const std::uint8_t* record) {
  delta::can::Frame f;
  f.id = static_cast<std::uint32_t>(record[1] | (record[2] & 0x07) << 8);
  f.dlc = static_cast<std::uint8_t>(record[3] % 9);
  std::memcpy(f.data.data(), record + 4, 8);
  return f;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Bit 7 of the first byte: SYNCs with a counter (TPDO3 echoes it).
  fw_linux::PortConfig config = fw_linux::Rig::config();
  if (size > 0 && (data[0] & 0x80) != 0) {
    config.sync_counter_overflow = static_cast<std::uint8_t>(2 + (data[0] >> 4 & 7));
  }
  fw_linux::Rig rig(config, {});
  // Records of 12 bytes: what to do, the 11-bit ID, the length, 8 data bytes.
  for (std::size_t at = 0; at + 12 <= size; at += 12) {
    const std::uint8_t* r = data + at;
    const delta::can::Frame f = frame_from(r);
    switch (r[0] & 3) {
      case 0: {
        delta::can::Received received;
        received.frame = f;
        rig.master.on_frame(received, 0);
        break;
      }
      case 1:
        rig.bus.emulator_.on_frame(f);
        break;
      case 2:
        rig.node.on_frame(f, 0);
        break;
      default:
        for (int n = 0; n <= (r[1] & 15); ++n) rig.cycle();
        break;
    }
  }
  for (int n = 0; n < 5; ++n) rig.cycle();
  if (static_cast<unsigned>(rig.controller.state()) >= delta::controller::kStateNames.size())
    std::abort();
  if (static_cast<unsigned>(rig.controller.fault()) >= delta::controller::kFaultNames.size())
    std::abort();
  if (rig.master.last_problem().size() > 1000) std::abort();
  return 0;
}
