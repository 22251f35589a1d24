// Fixtures of the identification tests: simulated logs with a known truth
// (the lumped plant and the multibody robot) and the options to fit them.
#pragma once

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "delta/robot_description.hpp"
#include "host_id/identify.hpp"
#include "host_id/regression.hpp"
#include "host_id/simulate.hpp"

namespace host_id::test {

// Rows of joint j scaled by sqrt(w_j): a weighted problem as an ordinary
// one, copied (the reference for the solve that scales rows as it reads them).
inline Regression weighted(const Equations& r, const std::array<double, 3>& w) {
  Regression out;
  out.psi = r.psi;
  out.tau = r.tau;
  out.t_s.assign(r.t_s.begin(), r.t_s.end());
  out.joint.assign(r.joint.begin(), r.joint.end());
  out.sample.assign(r.sample.begin(), r.sample.end());
  for (Eigen::Index row = 0; row < out.tau.size(); ++row) {
    const double s = std::sqrt(w[out.joint[static_cast<std::size_t>(row)]]);
    out.psi.row(row) *= s;
    out.tau(row) *= s;
  }
  return out;
}

inline DeltaLog simulated(std::uint64_t seed, double noise, unsigned bits, bool derivatives,
                          const std::string& trajectory = "fourier", double duration_s = 8.0) {
  SimulateOptions o;
  o.seed = seed;
  o.torque_noise = noise;
  o.encoder_bits = bits;
  o.with_derivatives = derivatives;
  o.trajectory = trajectory;
  o.duration_s = duration_s;
  o.base_frequency_hz = 0.25;
  DeltaLog log = simulate_log(o);
  log.name = "sim-" + std::to_string(seed);
  return log;
}

inline FitOptions least_squares(ModelOptions m = {}) {
  FitOptions f;
  f.model = m;
  f.method = Method::kLeastSquares;
  return f;
}

// The largest error against the truth: relative, or absolute (in the
// parameter's unit) where the truth is zero (the higher-fidelity model's sin
// term and coupling on a lumped robot).
inline double max_relative_error(const FitResult& r, const std::vector<double>& truth) {
  double worst = 0.0;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const double error = std::abs(r.parameters[i].value - truth[i]);
    worst = std::max(worst, truth[i] != 0.0 ? error / std::abs(truth[i]) : error);
  }
  return worst;
}

inline ModelOptions model_named(const std::string& name) {
  ModelOptions m;
  m.name = name;
  return m;
}

// Physics the fit does not share: the multibody (MuJoCo) robot, following a
// Fourier path under its PD controller, with the noise and encoder of a
// real log. Built so that the lumped model contains it (each rod's mass at
// its two ends, the arm's centre of mass on the arm line, plain Coulomb
// friction with the model's smoothing), the fit recovers its truth; with
// the default robot's bodies it does not, by what the lumped model lacks
// (docs/model.md).
inline delta::RobotDescription point_mass_robot() {
  delta::RobotDescription d = delta::default_robot_description();
  d.rod.elbow_cup_mass_kg += d.rod.tube_mass_kg / 2.0;
  d.rod.platform_cup_mass_kg += d.rod.tube_mass_kg / 2.0;
  d.rod.tube_mass_kg = 0.0;
  d.upper_arm.com_m.z = 0.0;
  for (delta::JointDrive& j : d.joints) {
    j.stribeck_friction_Nm = 0.0;
    j.friction_smoothing_rad_s = 0.01;
  }
  return d;
}

inline DeltaLog multibody_log(const delta::RobotDescription& robot, double base_frequency_hz = 0.2,
                              const std::string& trajectory = "fourier", std::uint64_t seed = 1) {
  SimulateOptions o;
  o.plant = SimulatedPlant::kMujoco;
  o.robot = robot;
  o.duration_s = 20.0;
  o.torque_noise = 0.015;
  o.encoder_bits = 17;
  o.base_frequency_hz = base_frequency_hz;
  o.trajectory = trajectory;
  o.seed = seed;
  return simulate_log(o);
}

// The default robot, heavier (twice the arm mass, a 0.5 kg payload), so
// that its torques are those of a working delta.
inline delta::RobotDescription heavy_robot() {
  delta::RobotDescription r = delta::default_robot_description();
  r.upper_arm.mass_kg *= 2.0;
  r.upper_arm.inertia.xx_kg_m2 *= 2.0;
  r.upper_arm.inertia.yy_kg_m2 *= 2.0;
  r.upper_arm.inertia.zz_kg_m2 *= 2.0;
  r.payload.mass_kg = 0.5;
  return r;
}

// A working delta (heavy_robot) whose arms differ by 3 %, with Stribeck
// friction and cogging at every joint; with `drive_train`, also the four
// effects of a real drive train (elastic gearboxes, torque constants off,
// currents filtered, load friction).
inline delta::RobotDescription flawed_robot(bool drive_train) {
  delta::RobotDescription r = heavy_robot();
  const double arm_scale[3] = {1.0, 1.03, 0.97};
  const double stiffness[3] = {3000.0, 3400.0, 2700.0};
  const double ratio[3] = {1.06, 0.95, 1.10};
  for (unsigned j = 0; j < 3; ++j) {
    delta::UpperArmBody arm = r.upper_arm;
    arm.mass_kg *= arm_scale[j];
    r.arm_bodies[j] = arm;
    r.joints[j].stribeck_friction_Nm = 0.02;
    r.joints[j].stribeck_velocity_rad_s = 0.1;
    r.joints[j].cogging_amplitude_Nm = 0.03;
    r.joints[j].cogging_periods_per_motor_rev = 6.0;
    if (!drive_train) continue;
    r.joints[j].rotor_inertia_kg_m2 = 3e-5;
    r.joints[j].gearbox_stiffness_Nm_per_rad = stiffness[j];
    r.joints[j].gearbox_damping_Nm_s_per_rad = 0.5;
    r.joints[j].torque_constant_ratio = ratio[j];
    r.joints[j].current_filter_time_constant_s = 0.5e-3;
    r.joints[j].load_friction_coefficient = 0.05;
  }
  return r;
}

inline FitResult fit_multibody_log(const delta::RobotDescription& robot, const std::string& model) {
  return fit_log(multibody_log(robot), least_squares(model_named(model)));
}

inline double estimate(const FitResult& r, const std::string& name) {
  for (const auto& e : r.parameters) {
    if (e.info.name == name) return e.value;
  }
  ADD_FAILURE() << "no parameter " << name;
  return 0.0;
}

// The rows of `r` (built in time order) with those of joints slower than
// min_speed_rad_s after the others, each group in its order: the order the
// fit asks preprocessing for, by the plain definition.
inline std::vector<Eigen::Index> fast_then_slow(const Regression& r, double min_speed_rad_s) {
  std::vector<Eigen::Index> fast, slow;
  for (std::size_t row = 0; row < r.rows(); ++row) {
    (std::abs(r.velocity_rad_s[row]) >= min_speed_rad_s ? fast : slow)
        .push_back(static_cast<Eigen::Index>(row));
  }
  fast.insert(fast.end(), slow.begin(), slow.end());
  return fast;
}

}  // namespace host_id::test
