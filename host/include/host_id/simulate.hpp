// `host_id simulate`: delta-log/1 files from known parameters by inverse
// dynamics, the source of the shipped examples and of test data with known
// truth.
#pragma once

#include <cstdint>
#include <string>

#include "delta/dynamics.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {

struct SimulateOptions {
  std::string trajectory{"fourier"};  // "fourier" or "pick-and-place"
  double duration_s{10.0};
  double sample_rate_hz{1000.0};
  std::uint64_t seed{1};
  unsigned harmonics{5};
  double base_frequency_hz{0.2};
  double amplitude_rad{0.35};    // worst-case joint amplitude of the Fourier path
  double torque_noise{0.0};      // Gaussian, as a fraction of each joint's RMS torque
  unsigned encoder_bits{0};      // quantise q to 2 pi / 2^bits; 0: off
  bool with_derivatives{false};  // write exact qd, qdd columns
  std::string name;              // the log's `trajectory` metadata
  delta::Geometry geometry{delta::kDefaultGeometry};
  delta::LumpedParameters parameters{delta::default_lumped_parameters()};
};

// Throws delta::InputError for options out of range or a trajectory that leaves
// the workspace.
DeltaLog simulate_log(const SimulateOptions& options);

}  // namespace host_id
