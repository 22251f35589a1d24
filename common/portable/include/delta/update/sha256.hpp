// SHA-256 (FIPS 180-4), streaming, for the firmware image's payload digest
// (docs/flashing.md). No heap; 108 bytes of state.
#pragma once

#include <array>
#include <cstdint>
#include <span>

namespace delta::update {

using Sha256Digest = std::array<std::uint8_t, 32>;

class Sha256 {
 public:
  void add(std::span<const std::uint8_t> bytes);
  // The digest of everything added; the object is spent afterwards.
  Sha256Digest finish();

 private:
  void compress(const std::uint8_t* block);

  std::array<std::uint32_t, 8> h_{0x6a09e667u, 0xbb67ae85u, 0x3c6ef372u, 0xa54ff53au,
                                  0x510e527fu, 0x9b05688cu, 0x1f83d9abu, 0x5be0cd19u};
  std::array<std::uint8_t, 64> block_{};
  std::uint32_t used_{0};  // bytes in block_
  std::uint64_t total_bytes_{0};
};

Sha256Digest sha256(std::span<const std::uint8_t> bytes);

}  // namespace delta::update
