// A log that cannot separate every parameter, for the base-parameter tests:
// a simulated Fourier log with exact qd/qdd columns, joint 3 held still at
// q3_rad and every torque recomputed by the lumped model with `truth`.
#pragma once

#include <stdexcept>

#include "delta/dynamics.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/simulate.hpp"

namespace testlogs {

inline host_id::DeltaLog log_with_joint3_held(double duration_s, double q3_rad,
                                              const delta::LumpedParameters& truth) {
  host_id::SimulateOptions o;
  o.duration_s = duration_s;
  o.with_derivatives = true;
  host_id::DeltaLog log = host_id::simulate_log(o);
  for (std::size_t k = 0; k < log.size(); ++k) {
    log.q[2][k] = q3_rad;
    log.qd[2][k] = 0.0;
    log.qdd[2][k] = 0.0;
    delta::JointState s;
    for (unsigned j = 0; j < 3; ++j) {
      s.q_rad[j] = log.q[j][k];
      s.qd_rad_s[j] = log.qd[j][k];
      s.qdd_rad_s2[j] = log.qdd[j][k];
    }
    delta::Joint3 tau{};
    if (delta::inverse_dynamics(log.geometry, truth, s, tau) != delta::KinematicsStatus::kOk) {
      throw std::runtime_error("held-joint log: a pose without kinematics");
    }
    for (unsigned j = 0; j < 3; ++j) log.tau[j][k] = tau[j];
  }
  return log;
}

}  // namespace testlogs
