// The vcan interface a HIL test runs on: the one hil/vcan-run created for it
// (its first --iface, exported as DELTA_VCAN), so that test suites that run
// side by side natively (ctest -j) each have a bus of their own.
#pragma once

#include <cstdlib>
#include <string>

namespace hil {

inline std::string vcan_interface() {
  const char* name = std::getenv("DELTA_VCAN");
  return name != nullptr && *name != '\0' ? name : "vcan0";
}

}  // namespace hil
