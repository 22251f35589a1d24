// The excitation trajectories the Linux port knows by name:
//   path1          5-harmonic Fourier excitation at 0.2 Hz, 2 periods (fit)
//   path2          5-harmonic Fourier excitation at 0.25 Hz, 2 periods (validation)
//   pick-and-place the default pick-and-place cycle, 3 times (validation)
// The Fourier paths come from common's make_fourier_excitation (the same
// generator as `host_id simulate`), converted once to the core's Q formats.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "fw/trajectory.hpp"
#include "fw_linux/config.hpp"

namespace fw_linux {

std::vector<std::string> trajectory_names();

// The named trajectory for this configuration (tick period, geometry);
// nullopt for an unknown name. Throws ConfigError when the trajectory does
// not fit the geometry.
std::optional<fw::TrajectoryConfig> named_trajectory(const std::string& name,
                                                     const PortConfig& config);

}  // namespace fw_linux
