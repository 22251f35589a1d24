#include "delta/drive_train_plant.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "delta/mujoco_plant.hpp"

namespace delta {

namespace {

// The current filter is the drive's (CurrentFilter), not the plant's.
bool ideal(const JointDrive& j) {
  return !j.elastic() && j.torque_constant_ratio == 1.0 && j.load_friction_coefficient == 0.0 &&
         j.cogging_amplitude_Nm == 0.0;
}

// The slope of the joint's friction (and of the load friction's smoothed
// sign) at qd: what makes the motor's small inertia stiff, taken
// implicitly.
double friction_slope(const JointDrive& j, double coulomb_Nm, double qd_rad_s) {
  const double c = std::cosh(qd_rad_s / j.friction_smoothing_rad_s);
  return j.viscous_friction_Nm_s_per_rad + coulomb_Nm / (j.friction_smoothing_rad_s * c * c);
}

}  // namespace

bool has_drive_train_effects(const RobotDescription& d) {
  return !std::all_of(d.joints.begin(), d.joints.end(), ideal);
}

RobotDescription arms_only(const RobotDescription& d) {
  RobotDescription arms = d;
  for (JointDrive& j : arms.joints) {
    if (!j.elastic()) continue;
    JointDrive rigid_arm_side;
    rigid_arm_side.rotor_inertia_kg_m2 = 0.0;
    rigid_arm_side.gear_ratio = j.gear_ratio;
    rigid_arm_side.friction_smoothing_rad_s = j.friction_smoothing_rad_s;
    j = rigid_arm_side;
  }
  return arms;
}

DriveTrainPlant::DriveTrainPlant(std::unique_ptr<Plant> arms,
                                 const std::array<JointDrive, 3>& joints)
    : arms_(std::move(arms)), joints_(joints) {
  const auto elastic =
      std::count_if(joints.begin(), joints.end(), [](const JointDrive& j) { return j.elastic(); });
  if (elastic != 0 && elastic != 3) {
    throw std::invalid_argument("a drive train is elastic in all three joints or in none");
  }
  elastic_ = elastic == 3;
  motor_step_s_ = 1.0;
  for (const JointDrive& j : joints_) {
    if (!j.elastic()) continue;
    // A twentieth of a period of the motor against its spring: the
    // resonance within 0.5 % of its frequency.
    const double omega = std::sqrt(j.gearbox_stiffness_Nm_per_rad / j.armature_kg_m2());
    motor_step_s_ = std::min(motor_step_s_, 0.05 * 2.0 * std::numbers::pi / omega);
  }
  if (elastic_) place_motors(arms_->state(), {});
}

void DriveTrainPlant::place_motors(const JointState& arm, const Joint3& gear_Nm) {
  if (!elastic_) return;  // the motors are the arms
  for (unsigned j = 0; j < 3; ++j) {
    motor_q_rad_[j] = arm.q_rad[j] + gear_Nm[j] / joints_[j].gearbox_stiffness_Nm_per_rad;
    motor_qd_rad_s_[j] = arm.qd_rad_s[j];
    motor_qdd_rad_s2_[j] = arm.qdd_rad_s2[j];
  }
}

double DriveTrainPlant::cogging_Nm(unsigned j, double motor_side_rad) const {
  const JointDrive& d = joints_[j];
  if (d.cogging_amplitude_Nm == 0.0) return 0.0;
  return d.cogging_amplitude_Nm *
         std::sin(d.cogging_periods_per_motor_rev * d.gear_ratio * motor_side_rad);
}

Joint3 DriveTrainPlant::gear_torque_Nm() const {
  const JointState a = arms_->state();
  Joint3 t{};
  for (unsigned j = 0; j < 3; ++j) {
    const JointDrive& d = joints_[j];
    t[j] = d.gearbox_stiffness_Nm_per_rad * (motor_q_rad_[j] - a.q_rad[j]) +
           d.gearbox_damping_Nm_s_per_rad * (motor_qd_rad_s_[j] - a.qd_rad_s[j]);
  }
  return t;
}

PlantStatus DriveTrainPlant::step(const Joint3& tau_Nm, double dt_s) {
  if (!fault_.empty()) return PlantStatus::kDiverged;
  const PlantStatus status = elastic_ ? step_elastic(tau_Nm, dt_s) : step_rigid(tau_Nm, dt_s);
  if (status != PlantStatus::kOk && fault_.empty()) fault_ = arms_->fault();
  return status;
}

// Rigid: the arm plant has the rotor and the friction; the drive train
// adds the torque constant, cogging and the load's friction (on the torque
// the motor puts through the gear).
PlantStatus DriveTrainPlant::step_rigid(const Joint3& tau_Nm, double dt_s) {
  const JointState a = arms_->state();
  Joint3 applied{};
  for (unsigned j = 0; j < 3; ++j) {
    const JointDrive& d = joints_[j];
    const double motor = d.torque_constant_ratio * tau_Nm[j];
    applied[j] = motor + cogging_Nm(j, a.q_rad[j]) -
                 d.load_friction_coefficient * std::abs(motor) *
                     std::tanh(a.qd_rad_s[j] / d.friction_smoothing_rad_s);
  }
  return arms_->step(applied, dt_s);
}

double DriveTrainPlant::advance_motor(unsigned j, double tau_applied_Nm, double qa_rad,
                                      double qad_rad_s, double h_s) {
  const JointDrive& d = joints_[j];
  const double k = d.gearbox_stiffness_Nm_per_rad, c = d.gearbox_damping_Nm_s_per_rad;
  const double inertia = d.armature_kg_m2();
  const double q0 = motor_q_rad_[j], v0 = motor_qd_rad_s_[j];
  const double gear0 = k * (q0 - qa_rad) + c * (v0 - qad_rad_s);
  // Friction: the joint's, with the gear's load friction in its Coulomb
  // term; linearised about v0 for the implicit step.
  const double load_Nm = d.load_friction_coefficient * std::abs(gear0);
  const double friction =
      joint_friction_Nm(d, v0) + load_Nm * std::tanh(v0 / d.friction_smoothing_rad_s);
  const double slope =
      friction_slope(d, d.coulomb_friction_Nm + d.stribeck_friction_Nm + load_Nm, v0);
  // Symplectic Euler for the spring (no numerical damping: the resonance
  // keeps its amplitude), the dissipative terms implicit in v1 (stable
  // whatever their slope against the small rotor inertia):
  // J (v1 - v0) / h = tau + cog - k (q0 - qa) - c (v1 - qad) - friction - slope (v1 - v0)
  const double rhs = inertia * v0 / h_s + tau_applied_Nm + cogging_Nm(j, q0) - k * (q0 - qa_rad) +
                     c * qad_rad_s - friction + slope * v0;
  const double v1 = rhs / (inertia / h_s + c + slope);
  motor_qdd_rad_s2_[j] = (v1 - v0) / h_s;
  motor_qd_rad_s_[j] = v1;
  motor_q_rad_[j] = q0 + h_s * v1;
  return gear0;  // what the arm gets over the sub-step, as the motor did
}

// Elastic: in arm steps of at most kArmStepElastic_s, each in motor
// sub-steps against the arm moving on at its velocity; the arm gets the
// gear torque's mean over its step.
PlantStatus DriveTrainPlant::step_elastic(const Joint3& tau_Nm, double dt_s) {
  const int arm_steps = std::max(1, static_cast<int>(std::ceil(dt_s / kArmStepElastic_s - 1e-9)));
  const double big_h = dt_s / arm_steps;
  const int motor_steps = std::max(1, static_cast<int>(std::ceil(big_h / motor_step_s_ - 1e-9)));
  const double h = big_h / motor_steps;
  Joint3 first_qdd{};
  for (int s = 0; s < arm_steps; ++s) {
    const JointState a = arms_->state();
    Joint3 gear_mean{};
    for (unsigned j = 0; j < 3; ++j) {
      const double tau = joints_[j].torque_constant_ratio * tau_Nm[j];
      for (int i = 0; i < motor_steps; ++i) {
        const double t = i * h;
        gear_mean[j] += advance_motor(j, tau, a.q_rad[j] + a.qd_rad_s[j] * t, a.qd_rad_s[j], h);
      }
      gear_mean[j] /= motor_steps;
      if (s == 0) first_qdd[j] = motor_qdd_rad_s2_[j];
    }
    const PlantStatus status = arms_->step(gear_mean, big_h);
    if (status != PlantStatus::kOk) return status;
  }
  motor_qdd_rad_s2_ = first_qdd;
  const std::string wrong = check_plant_state(state());
  if (!wrong.empty()) {
    fault_ = "the plant's motor side faulted: " + wrong;
    return PlantStatus::kDiverged;
  }
  return PlantStatus::kOk;
}

void DriveTrainPlant::stop() {
  arms_->stop();
  motor_qd_rad_s_ = {};  // the brake holds the motor
}

JointState DriveTrainPlant::state() const {
  if (!elastic_) return arms_->state();
  return JointState{motor_q_rad_, motor_qd_rad_s_, motor_qdd_rad_s2_};
}

const std::string& DriveTrainPlant::fault() const {
  return fault_.empty() ? arms_->fault() : fault_;
}

MultibodyRobot::MultibodyRobot(const RobotDescription& d, const Joint3& q0_rad,
                               const MujocoSettings& settings) {
  if (!has_drive_train_effects(d)) {
    own_arms_ = std::make_unique<MujocoPlant>(d, q0_rad, settings);
    arms_ = own_arms_.get();
    return;
  }
  MujocoSettings arm_settings = settings;
  if (std::any_of(d.joints.begin(), d.joints.end(),
                  [](const JointDrive& j) { return j.elastic(); })) {
    arm_settings.max_step_s = std::min(settings.max_step_s, DriveTrainPlant::kArmStepElastic_s);
  }
  auto arms = std::make_unique<MujocoPlant>(arms_only(d), q0_rad, arm_settings);
  arms_ = arms.get();
  drive_train_ = std::make_unique<DriveTrainPlant>(std::move(arms), d.joints);
}

MultibodyRobot::~MultibodyRobot() = default;

Plant& MultibodyRobot::outer() {
  return drive_train_ ? static_cast<Plant&>(*drive_train_) : *arms_;
}
const Plant& MultibodyRobot::outer() const {
  return drive_train_ ? static_cast<const Plant&>(*drive_train_) : *arms_;
}

void MultibodyRobot::place(const JointState& s) {
  arms_->place(s);
  if (drive_train_) drive_train_->place_motors(s, arms_->inverse_dynamics(s));
}

double CurrentFilter::update(double now, double dt_s) {
  if (!started_ || time_constant_s_ <= 0.0) {
    value_ = now;
    started_ = true;
    return value_;
  }
  value_ = now + (value_ - now) * std::exp(-dt_s / time_constant_s_);
  return value_;
}

}  // namespace delta
