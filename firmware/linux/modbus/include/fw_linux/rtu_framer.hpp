// Modbus RTU framing on a serial line (Modbus over Serial Line V1.02,
// 2.5.1.1). A frame ends where the line goes quiet for 3.5 character times.
// A USB adapter may deliver one frame in pieces with longer gaps, so a
// request of a function whose length the function code gives (01-06, 0F,
// 10, 16, 17) is taken as soon as that many bytes carry a good CRC. Any
// other frame (an unknown function such as diagnostics 0x08, a code of 0x80
// or more, another unit's reply) ends at the silence, and is whole if its
// CRC holds over all of it; so an unknown function is one frame, answered
// with exception 01, and the line stays in step.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace fw_linux {

// Modbus's CRC-16 (polynomial 0xA001 reflected, initial 0xFFFF); on the
// line low byte first.
std::uint16_t modbus_crc16(const std::uint8_t* bytes, std::size_t count);

// The silence that ends a frame at `baud`, in microseconds: 3.5 characters
// of 11 bits, and 1 750 us above 19 200 baud (the specification's fixed
// value there).
std::uint32_t rtu_frame_gap_us(std::uint32_t baud);

class RtuFramer {
 public:
  static constexpr std::size_t kMaxAdu = 256;  // unit + 253 bytes of PDU + CRC

  enum class Next {
    kNothing,    // the buffer is empty
    kNeedMore,   // a known function's request, not yet whole
    kFrame,      // a known function's request, whole and with a good CRC
    kAtSilence,  // the frame ends where the line goes quiet
  };

  std::uint8_t* space() { return buffer_.data() + size_; }
  std::size_t space_left() const { return buffer_.size() - size_; }
  void added(std::size_t n) { size_ += n; }

  // What the buffer starts with; on kFrame, the frame's length.
  Next next(std::size_t& frame_length) const;
  // The line went quiet: whether the whole buffer is one frame with a good
  // CRC (its length in frame_length). Either way the caller then clears.
  bool whole_at_silence(std::size_t& frame_length) const;

  const std::uint8_t* data() const { return buffer_.data(); }
  void consume(std::size_t n);
  void clear() { size_ = 0; }
  bool empty() const { return size_ == 0; }

 private:
  std::array<std::uint8_t, kMaxAdu> buffer_{};
  std::size_t size_{0};
};

}  // namespace fw_linux
