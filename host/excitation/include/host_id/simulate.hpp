// `host_id simulate`: delta-log/1 files with known truth, the source of the
// shipped examples and of test data. Two plants:
//   - lumped: the torques by inverse dynamics of the lumped model along the
//     path (exactly the model `fit --model lumped` estimates);
//   - mujoco: the multibody robot of a robot description follows the path
//     under a stiff joint PD controller with feed-forward from its lumped
//     model, and the log has the applied torques (tracking error, friction
//     shape, forearm inertia: what no identification model contains
//     exactly).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "delta/dynamics.hpp"
#include "delta/robot_description.hpp"
#include "delta/trajectory.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {

enum class SimulatedPlant : std::uint8_t { kLumped, kMujoco };

struct SimulateOptions {
  SimulatedPlant plant{SimulatedPlant::kLumped};
  std::string trajectory{"fourier"};  // "fourier", "pick-and-place" or "file"
  // trajectory "file": a trajectory file's excitation (delta-trajectory/1),
  // from rest to rest as the controller runs it, at rest after its end.
  std::optional<delta::BlendedFourierTrajectory> trajectory_file;
  double duration_s{10.0};
  double sample_rate_hz{1000.0};
  std::uint64_t seed{1};
  unsigned harmonics{5};
  double base_frequency_hz{0.2};
  double amplitude_rad{0.35};      // worst-case joint amplitude of the Fourier path
  double segment_duration_s{0.4};  // of the pick-and-place path, 0.1 to 10 s
  double torque_noise{0.0};        // Gaussian, as a fraction of each joint's RMS torque
  unsigned encoder_bits{0};        // quantise q to 2 pi / 2^bits; 0: off
  bool with_derivatives{false};    // write the plant's own qd, qdd columns
  // --plant mujoco: also write the arm side's encoders, qa1..qa3 (the arm's
  // angle behind an elastic gearbox; docs/log-format.md), quantised as q.
  bool arm_encoders{false};
  std::string name;  // the log's `trajectory` metadata
  // The lumped plant's robot:
  delta::Geometry geometry{delta::kDefaultGeometry};
  delta::LumpedParameters parameters{delta::default_lumped_parameters()};
  // The multibody plant's robot (its geometry and gravity are the log's):
  delta::RobotDescription robot{delta::default_robot_description()};
  // Called now and then (every 1 % of the samples) with the samples done.
  std::function<void(std::size_t done, std::size_t total)> progress;
};

// Throws delta::InputError for options out of range or a trajectory that leaves
// the workspace.
DeltaLog simulate_log(const SimulateOptions& options);

// The joint states the simulation follows, as a function of time (for a
// check of its limits before it runs). Throws as simulate_log does.
std::function<delta::JointState(double)> simulated_path(const SimulateOptions& options);

}  // namespace host_id
