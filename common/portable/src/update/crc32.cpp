#include "delta/update/crc32.hpp"

#include <array>

namespace delta::update {
namespace {

constexpr std::array<std::uint32_t, 256> make_table() {
  std::array<std::uint32_t, 256> t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int bit = 0; bit < 8; ++bit) c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
    t[i] = c;
  }
  return t;
}

constexpr std::array<std::uint32_t, 256> kTable = make_table();

}  // namespace

void Crc32::add(std::span<const std::uint8_t> bytes) {
  std::uint32_t c = state_;
  for (const std::uint8_t b : bytes) c = kTable[(c ^ b) & 0xFFu] ^ (c >> 8);
  state_ = c;
}

std::uint32_t crc32(std::span<const std::uint8_t> bytes) {
  Crc32 c;
  c.add(bytes);
  return c.value();
}

}  // namespace delta::update
