// The custom Fourier trajectory's holding-register block (docs/modbus.md,
// trajectory 3 "custom"), written once for the host that uploads it and the
// controller that runs it: a trajectory as the block's raw words and back.
#pragma once

#include <cstdint>
#include <vector>

#include "delta/modbus/register_map.hpp"
#include "delta/trajectory.hpp"

namespace delta {

// The words of registers kCustomFirst .. kCustomFirst + kCustomCount - 1.
// Throws InputError naming the register where a value does not fit (more
// than 6 harmonics, a frequency that is not a whole mHz in 1-5000, a blend
// outside 1-60000 ms, periods outside 1-100, an angle beyond +-2.147 rad).
std::vector<std::uint16_t> custom_trajectory_block(const BlendedFourierTrajectory& t);

// The trajectory of a block (the same words). Harmonics 0 gives a
// trajectory without terms (nothing uploaded); the caller's check refuses it.
BlendedFourierTrajectory custom_trajectory_of(const std::uint16_t* block);

}  // namespace delta
