// The Linux programs' one clock (the controller's port, the emulator, the
// SDO channel): CLOCK_MONOTONIC in microseconds.
#pragma once

#include <time.h>

#include <cstdint>

namespace delta {

inline std::uint64_t monotonic_us() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000u +
         static_cast<std::uint64_t>(ts.tv_nsec) / 1000u;
}

}  // namespace delta
