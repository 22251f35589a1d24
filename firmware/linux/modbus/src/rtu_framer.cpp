#include "fw_linux/rtu_framer.hpp"

#include <cstring>
#include <optional>

namespace fw_linux {

std::uint16_t modbus_crc16(const std::uint8_t* bytes, std::size_t count) {
  std::uint16_t crc = 0xFFFF;
  for (std::size_t i = 0; i < count; ++i) {
    crc ^= bytes[i];
    for (int b = 0; b < 8; ++b) {
      crc = (crc & 1u) != 0 ? static_cast<std::uint16_t>((crc >> 1) ^ 0xA001u)
                            : static_cast<std::uint16_t>(crc >> 1);
    }
  }
  return crc;
}

std::uint32_t rtu_frame_gap_us(std::uint32_t baud) {
  if (baud == 0 || baud > 19200) return 1750;
  return static_cast<std::uint32_t>((35ull * 11ull * 1000000ull + 10ull * baud - 1) /
                                    (10ull * baud));
}

namespace {

// The length of a request of a function whose length the function code
// and its leading fields give (Modbus Application Protocol V1.1b3, 6.x),
// unit and CRC included; nullopt for other functions, or while the field
// that gives it has not arrived.
std::optional<std::size_t> request_length(const std::uint8_t* b, std::size_t size) {
  switch (b[1]) {
    case 0x01:  // read coils, discrete inputs, holding, input registers
    case 0x02:
    case 0x03:
    case 0x04:
    case 0x05:  // write single coil, register
    case 0x06:
      return 8;
    case 0x0F:  // write multiple coils, registers: byte count at 6
    case 0x10:
      if (size < 7) return std::nullopt;
      return std::size_t{9} + b[6];
    case 0x16:  // mask write register
      return 10;
    case 0x17:  // read/write multiple registers: byte count at 10
      if (size < 11) return std::nullopt;
      return std::size_t{13} + b[10];
    default:
      return std::nullopt;
  }
}

bool crc_holds(const std::uint8_t* b, std::size_t length) {
  const std::uint16_t crc = modbus_crc16(b, length - 2);
  return b[length - 2] == (crc & 0xFF) && b[length - 1] == (crc >> 8);
}

bool length_known_from(std::uint8_t function) {
  return (function >= 0x01 && function <= 0x06) || function == 0x0F || function == 0x10 ||
         function == 0x16 || function == 0x17;
}

}  // namespace

RtuFramer::Next RtuFramer::next(std::size_t& frame_length) const {
  if (size_ == 0) return Next::kNothing;
  if (size_ < 2) return Next::kNeedMore;
  if (!length_known_from(buffer_[1])) return Next::kAtSilence;
  const std::optional<std::size_t> length = request_length(buffer_.data(), size_);
  if (!length) return Next::kNeedMore;
  if (*length > kMaxAdu) return Next::kAtSilence;  // no such request: let the silence end it
  if (size_ < *length) return Next::kNeedMore;
  if (!crc_holds(buffer_.data(), *length)) return Next::kAtSilence;  // not a request: a reply?
  frame_length = *length;
  return Next::kFrame;
}

bool RtuFramer::whole_at_silence(std::size_t& frame_length) const {
  if (size_ < 4 || !crc_holds(buffer_.data(), size_)) return false;
  frame_length = size_;
  return true;
}

void RtuFramer::consume(std::size_t n) {
  std::memmove(buffer_.data(), buffer_.data() + n, size_ - n);
  size_ -= n;
}

}  // namespace fw_linux
