// Excitation trajectories in double, with exact derivatives: Fourier series
// in joint space, and pick-and-place paths in Cartesian space through the
// inverse kinematics.
#pragma once

#include <array>
#include <vector>

#include "delta/dynamics.hpp"

namespace delta {

// q_i(t) = q0_i + sum_k [ a_ik / (k w) sin(k w t) - b_ik / (k w) cos(k w t) ],
// w = 2 pi base_frequency_hz. a and b are velocity amplitudes in rad/s.
struct FourierTrajectory {
  double base_frequency_hz{0.2};
  Joint3 q0_rad{};
  std::array<std::vector<double>, 3> a_rad_s;  // one entry per harmonic
  std::array<std::vector<double>, 3> b_rad_s;

  JointState at(double t_s) const;
};

// A Fourier excitation as the controller runs it (firmware/core's
// Trajectory, in double): q = q0 + w(t) (f(t) - q0) with f the Fourier
// series, faded in from rest at q0 over blend_s by the minimum-jerk window
// w, `periods` whole periods, and faded out to rest. t runs from 0 to
// duration_s(); the series' phase starts at t = 0.
struct BlendedFourierTrajectory {
  FourierTrajectory fourier;
  double blend_s{1.0};
  unsigned periods{2};
  double duration_s() const { return 2.0 * blend_s + periods / fourier.base_frequency_hz; }
  JointState at(double t_s) const;
};

// The controller's named Fourier excitations (docs/firmware.md): the
// generator's arguments, so that the firmware and the host build the same.
struct FourierPreset {
  const char* name;
  unsigned long long seed;
  double base_frequency_hz;
  unsigned harmonics;
  double amplitude_rad;
  Vec3<double> centre_m;
  unsigned periods;
};
// nullptr for a name that is not a Fourier preset.
const FourierPreset* fourier_preset(const char* name);

// Moves between Cartesian points with minimum-jerk (quintic) segments of
// equal duration, cycling through the points; q, qd, qdd follow from the
// inverse and velocity kinematics.
struct PickAndPlaceTrajectory {
  Geometry geometry{kDefaultGeometry};
  std::vector<Vec3<double>> points_m;  // visited in order, then back to the first
  double segment_duration_s{0.5};

  // Returns kOk, or the kinematics status of an unreachable point.
  KinematicsStatus at(double t_s, JointState& out) const;
};

// A Fourier excitation with pseudo-random coefficients from seed, around the
// joint angles of the platform position centre_m, scaled down until every
// sample of one period lies inside the workspace limits. Returns false if no
// scale works.
bool make_fourier_excitation(const Geometry& g, const Vec3<double>& centre_m, unsigned harmonics,
                             double base_frequency_hz, double max_amplitude_rad,
                             unsigned long long seed, FourierTrajectory& out);

// The default pick-and-place cycle: up, across, down and back, for the
// default robot's workspace.
PickAndPlaceTrajectory default_pick_and_place(const Geometry& g);

}  // namespace delta
