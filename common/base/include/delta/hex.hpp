#pragma once

#include <cstdint>
#include <string>

namespace delta {

// "0x0000DE17": a 32-bit identity, CRC or code as CANopen tools print it.
std::string hex32(std::uint32_t v);

}  // namespace delta
