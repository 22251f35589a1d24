// Modbus TCP framing by the MBAP header, as the Modbus TCP specification
// frames it: 7 bytes (transaction id, protocol id 0, length, unit id), then
// length - 1 bytes of PDU. Whatever the function code, the header says
// where a request ends, so an unknown function (diagnostics 0x08, a code
// with an odd payload) is one whole frame, answered with exception 01, and
// the stream stays in step. Bytes arrive as the socket gives them; the
// framer never blocks.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace fw_linux {

class MbapFramer {
 public:
  static constexpr std::size_t kHeader = 7;
  static constexpr std::size_t kMaxAdu = 260;  // Modbus TCP: 7 + 253

  enum class Next { kNeedMore, kFrame, kBadHeader };

  // Room for the next bytes, and how many fit.
  std::uint8_t* space() { return buffer_.data() + size_; }
  std::size_t space_left() const { return buffer_.size() - size_; }
  void added(std::size_t n) { size_ += n; }

  // What the buffer starts with: a whole frame (its length in frame_length),
  // not yet a whole one, or a header no Modbus TCP frame has (protocol id
  // not 0, a length below 2 or beyond the largest ADU).
  Next next(std::size_t& frame_length) const;
  const std::uint8_t* data() const { return buffer_.data(); }
  void consume(std::size_t n);
  bool empty() const { return size_ == 0; }

 private:
  std::array<std::uint8_t, 2 * kMaxAdu> buffer_{};
  std::size_t size_{0};
};

}  // namespace fw_linux
