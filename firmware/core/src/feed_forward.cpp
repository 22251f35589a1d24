#include "fw/feed_forward.hpp"

#include "delta/fixed/math.hpp"

namespace fw {

using delta::fx::mul;

KinematicsStatus feed_forward_torque(const FeedForwardConfig& config,
                                     const delta::fx::JointStateQ& ref, Joint3Q12_19& tau_Nm) {
  tau_Nm = {};
  switch (config.mode) {
    case FeedForwardMode::kOff:
      return KinematicsStatus::kOk;
    case FeedForwardMode::kNominal:
      for (unsigned j = 0; j < 3; ++j) {
        tau_Nm[j] = mul<Q12_19>(config.nominal.arm_inertia_kg_m2, ref.qdd_rad_s2[j]) -
                    mul<Q12_19>(config.nominal.gravity_moment_Nm, delta::fx::cos(ref.q_rad[j]));
      }
      return KinematicsStatus::kOk;
    case FeedForwardMode::kModel:
      return delta::fx::model_torque(config.model, ref, tau_Nm);
  }
  return KinematicsStatus::kOk;
}

}  // namespace fw
