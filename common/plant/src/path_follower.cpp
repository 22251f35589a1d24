#include "delta/path_follower.hpp"

namespace delta {

KinematicsStatus PathFollower::torque(const JointState& desired, const JointState& actual,
                                      Joint3& tau_Nm) const {
  Joint3 ff{};
  const KinematicsStatus st = inverse_dynamics(geometry_, feed_forward_, desired, ff);
  if (st != KinematicsStatus::kOk) return st;
  for (unsigned j = 0; j < 3; ++j) {
    tau_Nm[j] = ff[j] + gains_.stiffness_Nm_per_rad * (desired.q_rad[j] - actual.q_rad[j]) +
                gains_.damping_Nm_s_per_rad * (desired.qd_rad_s[j] - actual.qd_rad_s[j]);
  }
  return KinematicsStatus::kOk;
}

}  // namespace delta
