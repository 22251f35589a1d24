// What the SDO client and server share inside: the segment size and two
// byte helpers. <algorithm> is not used: newlib's pulls floating point into
// the Cortex-M build, which may not touch the FPU.
#pragma once

#include <cstddef>
#include <cstdint>

namespace delta::can::sdo::detail {

inline constexpr std::uint32_t kSegmentBytes = 7;  // data bytes of a segment

constexpr std::uint32_t smaller(std::uint32_t a, std::uint32_t b) {
  return a < b ? a : b;
}

inline void copy_bytes(const std::uint8_t* from, std::size_t n, std::uint8_t* to) {
  for (std::size_t i = 0; i < n; ++i) to[i] = from[i];
}

}  // namespace delta::can::sdo::detail
