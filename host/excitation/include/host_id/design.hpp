// `host_id design`: an excitation designed for the user's robot
// (docs/design-excitation.md, "Designing an excitation"). Fourier joint
// trajectories, run as the controller runs them (faded in from rest, whole
// periods, faded out), with coefficients found by PSO to minimise the
// condition number of the chosen model's column-scaled regressor (or to
// maximise the log determinant of its information matrix) along the whole
// trajectory, subject on every sample to the joint range, velocity and
// acceleration limits, the workspace and the drives' torque limit under
// the robot's nominal parameters.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "delta/robot_description.hpp"
#include "delta/trajectory.hpp"
#include "host_id/model.hpp"
#include "host_id/pso.hpp"

namespace host_id {

// The firmware's defaults (docs/firmware.md): limits.* and gains.max_torque_Nm.
struct DesignLimits {
  double min_rad{-1.2};
  double max_rad{1.4};
  double max_velocity_rad_s{6.0};
  double max_acceleration_rad_s2{150.0};
  double max_torque_Nm{8.0};
};

// `base` with the limits the robot description gives (its "limits").
DesignLimits with_robot_limits(DesignLimits base, const delta::RobotLimits& robot);

// kCalibration: a torque-scale calibration run (fit --calibrate-torque,
// docs/payload.md): the condition number over the square of the smallest
// joint's RMS payload torque per kilogram, so that a payload's torque
// stands out of what no model holds (cogging) on every joint while the
// robot's parameters stay identified.
enum class DesignCriterion { kConditionNumber, kLogDet, kCalibration };

struct DesignOptions {
  ModelOptions model;  // whose regressor is conditioned
  unsigned harmonics{5};
  double base_frequency_hz{0.2};
  double blend_s{1.0};
  unsigned periods{2};
  delta::Vec3<double> centre_m{0.0, 0.0, -0.42};  // q0: the joint angles of this point
  double max_amplitude_rad{0.5};                  // of harmonic k's position amplitude: this / k
  DesignCriterion criterion{DesignCriterion::kConditionNumber};
  DesignLimits limits;
  // The search keeps this fraction of every limit, for the samples between
  // those it evaluates; the result is then checked at 1 kHz against the
  // full limits.
  double margin{0.97};
  double evaluation_rate_hz{25.0};
  PsoOptions pso;
  // For the expected standard deviations: white torque noise of this size
  // on a log sampled at this rate.
  double torque_noise_Nm{0.01};
  double log_rate_hz{500.0};
};

DesignOptions default_design_options();

struct ExcitationQuality {
  bool feasible{false};
  std::string violation;  // the first limit broken: what, at which time and joint
  double condition_number_scaled{0};
  double log_det_scaled{0};  // log det of the column-scaled information matrix
  double largest_torque_Nm{0};
  // Each joint's RMS torque per kilogram of payload at the platform (N m/kg).
  std::array<double, 3> payload_torque_rms_Nm_per_kg{};
  // Per parameter of the model: the expected standard deviation at the
  // options' noise and rate, and relative to the nominal value (NaN where
  // the nominal value is 0).
  std::vector<double> std_dev, rel_std_percent;
  std::vector<double> nominal;
};

// The quality of a trajectory on the robot, its limits checked every
// 1 / check_rate_hz.
ExcitationQuality excitation_quality(const delta::BlendedFourierTrajectory& t,
                                     const DesignOptions& options,
                                     const delta::RobotDescription& robot,
                                     double check_rate_hz = 1000.0);

// The first of the options' limits a path breaks over [0, duration_s]
// (joint range, velocity, acceleration, workspace, the torque with the
// robot's nominal parameters), checked every 1 / check_rate_hz; "" if none.
std::string limit_violation(const std::function<delta::JointState(double)>& path, double duration_s,
                            const DesignOptions& options, const delta::RobotDescription& robot,
                            double check_rate_hz = 1000.0);

struct DesignResult {
  delta::BlendedFourierTrajectory trajectory;
  ExcitationQuality quality;
  PsoResult pso;
  double seconds{0};
};

// Throws delta::InputError for options out of range or a centre outside
// the workspace, and when no feasible excitation is found (naming the limit
// the best candidate breaks).
DesignResult design_excitation(const DesignOptions& options, const delta::RobotDescription& robot);

// A named preset (path1, path2) as the controller runs it on this robot.
delta::BlendedFourierTrajectory preset_trajectory(const std::string& name,
                                                  const delta::RobotDescription& robot,
                                                  double blend_s);

}  // namespace host_id
