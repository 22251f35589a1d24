// libFuzzer harness: Modbus RTU framing (RtuFramer), fed in chunks with or
// without a silence after each, as the server's serial loop feeds it.
// Frames it yields carry a good CRC and fit the largest ADU; a known
// function's frame has that function's length; nothing reads or writes
// outside its buffer.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "fw_linux/rtu_framer.hpp"

namespace {

using fw_linux::RtuFramer;

void check_frame(const std::uint8_t* frame, std::size_t length) {
  if (length < 4 || length > RtuFramer::kMaxAdu) std::abort();
  const std::uint16_t crc = fw_linux::modbus_crc16(frame, length - 2);
  if (frame[length - 2] != (crc & 0xFF) || frame[length - 1] != (crc >> 8)) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  RtuFramer framer;
  bool too_long = false;
  std::size_t at = 0;
  while (at < size) {
    // Each chunk's first byte: its length (low 7 bits, plus one) and
    // whether the line goes quiet after it (high bit).
    const bool silence_after = (data[at] & 0x80) != 0;
    const std::size_t want = std::size_t{data[at] & 0x7Fu} + 1;
    ++at;
    const std::size_t chunk = std::min(want, size - at);
    const std::size_t fits = std::min(chunk, framer.space_left());
    std::memcpy(framer.space(), data + at, fits);
    framer.added(fits);
    too_long = too_long || fits < chunk;
    at += chunk;
    std::size_t length = 0;
    while (!too_long && framer.next(length) == RtuFramer::Next::kFrame) {
      check_frame(framer.data(), length);
      framer.consume(length);
    }
    if (silence_after) {
      if (!too_long && framer.whole_at_silence(length)) check_frame(framer.data(), length);
      framer.clear();
      too_long = false;
    }
  }
  return 0;
}
