// CRC-32 as in IEEE 802.3 and zlib (reflected polynomial 0xEDB88320,
// initial value and final XOR 0xFFFFFFFF): the check of a firmware image's
// program (docs/flashing.md) and the value of object 0x1F56. Streaming, no
// table in RAM: a 256-entry table in read-only memory, built at compile time.
// crc32 of "123456789" is 0xCBF43926.
#pragma once

#include <cstdint>
#include <span>

namespace delta::update {

class Crc32 {
 public:
  void add(std::span<const std::uint8_t> bytes);
  std::uint32_t value() const { return ~state_; }

 private:
  std::uint32_t state_{0xFFFFFFFFu};
};

std::uint32_t crc32(std::span<const std::uint8_t> bytes);

}  // namespace delta::update
