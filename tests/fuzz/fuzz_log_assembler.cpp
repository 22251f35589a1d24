// libFuzzer harness: the recorder's frame assembler, fed any sequence of
// CAN frames (each input: 1 byte of DLC and id selector, then 8 data bytes
// per frame). It must never crash, and what it emits is in seq order.
#include <cstdint>
#include <cstdlib>

#include "delta/can/protocol.hpp"
#include "host_id/recorder.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace p = delta::can::protocol;
  const std::uint32_t ids[] = {p::kLogA.base_id, p::kLogB.base_id, p::kLogC.base_id,
                               p::kSync.base_id, 0x7FF};
  host_id::LogAssembler assembler;
  std::uint64_t last_seq = 0;
  bool any = false;
  const auto check = [&](const std::vector<host_id::LogSample>& samples) {
    for (const auto& s : samples) {
      if (any && s.seq <= last_seq) std::abort();
      last_seq = s.seq;
      any = true;
    }
  };
  for (std::size_t at = 0; at + 9 <= size; at += 9) {
    delta::can::Frame f{};
    f.id = ids[data[at] % 5];
    f.dlc = static_cast<std::uint8_t>((data[at] >> 3) % 9);
    for (unsigned i = 0; i < 8; ++i) f.data[i] = data[at + 1 + i];
    assembler.feed(f);
    check(assembler.take_complete());
  }
  assembler.finish();
  check(assembler.take_complete());
  return 0;
}
