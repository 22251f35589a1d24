// libFuzzer harness: Modbus TCP framing (MbapFramer), fed in arbitrary
// chunks. Frames it yields are whole and within the largest ADU; a bad
// header stops the stream; nothing reads or writes outside its buffer.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>

#include "fw_linux/mbap_framer.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  fw_linux::MbapFramer framer;
  std::size_t at = 0;
  while (at < size) {
    // The first byte of each chunk says how long the chunk is.
    const std::size_t chunk = std::min({std::size_t{data[at]} + 1, size - at, framer.space_left()});
    if (chunk == 0) std::abort();  // the buffer filled without a frame
    std::memcpy(framer.space(), data + at, chunk);
    framer.added(chunk);
    at += chunk;
    std::size_t length = 0;
    for (;;) {
      const auto next = framer.next(length);
      if (next == fw_linux::MbapFramer::Next::kBadHeader) return 0;
      if (next == fw_linux::MbapFramer::Next::kNeedMore) break;
      if (length < 8 || length > fw_linux::MbapFramer::kMaxAdu) std::abort();
      framer.consume(length);
    }
  }
  return 0;
}
