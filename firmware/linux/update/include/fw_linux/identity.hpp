// The controller's identity (0x1018, docs/protocol.md), the version as the
// revision. delta_boot and the program download check images against it.
#pragma once

#include <cstdint>

#include "delta/can/protocol.hpp"
#include "delta/update/image.hpp"

namespace fw_linux {

using delta::can::protocol::kControllerProductCode;
using delta::can::protocol::kControllerVendorId;

// 0x1018 for a program of `version`: revision = major << 16 | minor.
constexpr delta::update::Identity controller_identity(const delta::update::Version& version) {
  return {kControllerVendorId, kControllerProductCode,
          (std::uint32_t{version.major} << 16) | version.minor};
}

}  // namespace fw_linux
