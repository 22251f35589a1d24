#include <cmath>
#include <sstream>

#include "delta/plant.hpp"

namespace delta {

std::string check_plant_state(const JointState& s) {
  for (unsigned j = 0; j < 3; ++j) {
    if (!std::isfinite(s.q_rad[j]) || !std::isfinite(s.qd_rad_s[j]) ||
        !std::isfinite(s.qdd_rad_s2[j])) {
      return "joint " + std::to_string(j + 1) + "'s state is not finite";
    }
    if (std::abs(s.qd_rad_s[j]) > kPlantMaxSpeed_rad_s) {
      std::ostringstream m;
      m << "joint " << j + 1 << " runs away at " << s.qd_rad_s[j] << " rad/s (more than "
        << kPlantMaxSpeed_rad_s << ")";
      return m.str();
    }
  }
  return {};
}

LumpedPlant::LumpedPlant(const Geometry& geometry, const LumpedParameters& parameters,
                         const Joint3& q0_rad)
    : geometry_(geometry), parameters_(parameters) {
  state_.q_rad = q0_rad;
}

void LumpedPlant::set_fault(const JointState& before, const std::string& why) {
  std::ostringstream m;
  m << "the plant faulted at " << time_s_ << " s: " << why;
  fault_ = m.str();
  state_ = before;  // the last sane state, held
  state_.qd_rad_s = {};
}

PlantStatus LumpedPlant::step(const Joint3& tau_Nm, double dt_s) {
  if (!fault_.empty()) return PlantStatus::kDiverged;
  const JointState before = state_;
  if (forward_dynamics(geometry_, parameters_, state_.q_rad, state_.qd_rad_s, tau_Nm,
                       state_.qdd_rad_s2) == KinematicsStatus::kOk &&
      integrate_rk4(geometry_, parameters_, tau_Nm, dt_s, 1, state_.q_rad, state_.qd_rad_s) ==
          KinematicsStatus::kOk) {
    const std::string wrong = check_plant_state(state_);
    if (wrong.empty()) {
      time_s_ += dt_s;
      return PlantStatus::kOk;
    }
    set_fault(before, wrong);
    return PlantStatus::kDiverged;
  }
  set_fault(before, "the robot reached a pose without forward kinematics");
  return PlantStatus::kNoKinematics;
}

}  // namespace delta
