#include "delta/hex.hpp"

#include <cstdio>

namespace delta {

std::string hex32(std::uint32_t v) {
  char text[16];
  std::snprintf(text, sizeof text, "0x%08X", v);
  return text;
}

}  // namespace delta
