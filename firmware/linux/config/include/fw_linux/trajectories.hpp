// The excitation trajectories the Linux port knows by name:
//   path1          5-harmonic Fourier excitation at 0.2 Hz, 2 periods (fit)
//   path2          5-harmonic Fourier excitation at 0.25 Hz, 2 periods (validation)
//   pick-and-place the default pick-and-place cycle, 3 times (validation)
//   custom         the Fourier trajectory of the custom holding registers
//                  (uploaded over Modbus, or from the configuration's
//                  trajectory_file)
// The Fourier paths come from common's make_fourier_excitation (the same
// generator as `host_id simulate`), converted once to the core's Q formats.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "delta/trajectory.hpp"
#include "fw/trajectory.hpp"
#include "fw_linux/config.hpp"

namespace fw_linux {

// The names, in the order of their ids (the Modbus register `trajectory`).
std::vector<std::string> trajectory_names();

// What a user may change of a named trajectory.
struct TrajectoryParams {
  std::uint16_t scale_permille{1000};  // amplitude: Fourier terms, waypoints about their centre
  std::uint16_t repetitions{0};        // Fourier periods or pick-and-place cycles; 0: the preset's
};

// A Fourier excitation in the core's Q formats, ticking every period_us,
// its amplitudes scaled by scale_permille / 1000. Throws ConfigError for
// more harmonics than the core has, a base frequency that is not a whole
// number of mHz, or a value outside its Q format.
fw::TrajectoryConfig fourier_config(const delta::BlendedFourierTrajectory& t,
                                    std::uint32_t period_us, std::uint16_t scale_permille = 1000);

// The custom trajectory (trajectory 3) of the holding registers' custom
// block (delta::custom_trajectory_block's words). Throws ConfigError where
// the block holds none (custom_harmonics 0) or a value the core cannot take.
fw::TrajectoryConfig custom_trajectory(const std::uint16_t* block, const PortConfig& config,
                                       const TrajectoryParams& params = {});

// The named trajectory for this configuration (tick period, geometry);
// nullopt for an unknown name. Throws ConfigError when the trajectory does
// not fit the geometry. Limits are checked later, by fw::check_trajectory.
std::optional<fw::TrajectoryConfig> named_trajectory(const std::string& name,
                                                     const PortConfig& config,
                                                     const TrajectoryParams& params = {});

}  // namespace fw_linux
