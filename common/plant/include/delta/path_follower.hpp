// A stiff joint PD controller with model feed-forward, as a real robot's
// controller follows a path: the torque a simulated robot gets while it
// follows a trajectory, so that simulated torques contain tracking error
// and what the controller's model does not know, as real ones do.
#pragma once

#include "delta/dynamics.hpp"

namespace delta {

struct JointPdGains {
  double stiffness_Nm_per_rad{200.0};  // about 20 Hz on a 0.0125 kg m^2 joint
  double damping_Nm_s_per_rad{2.2};    // about 0.7 of critical there
};

class PathFollower {
 public:
  // feed_forward: the controller's (nominal) model of the robot.
  PathFollower(const Geometry& geometry, const LumpedParameters& feed_forward,
               JointPdGains gains = {})
      : geometry_(geometry), feed_forward_(feed_forward), gains_(gains) {}

  // tau = inverse_dynamics(desired) + Kp (q_d - q) + Kd (qd_d - qd).
  // Returns kUnreachable or kSingular where the desired state has no
  // kinematics (tau untouched).
  KinematicsStatus torque(const JointState& desired, const JointState& actual,
                          Joint3& tau_Nm) const;

 private:
  Geometry geometry_;
  LumpedParameters feed_forward_;
  JointPdGains gains_;
};

}  // namespace delta
