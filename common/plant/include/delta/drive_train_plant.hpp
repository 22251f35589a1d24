// The drive train between the drives and the arms as real ones are
// (docs/robot-description.md, "The drive train"), around a plant of the
// arms:
//   - the torque constant: the arm gets torque_constant_ratio times the
//     torque the drive commands (and reports: both are the nominal constant
//     times the current);
//   - cogging: amplitude * sin(periods * motor angle);
//   - load-dependent gear friction: coefficient * |gear torque|, opposing
//     the motion like the Coulomb term;
//   - an elastic gearbox: the motor (its rotor inertia, the joint's
//     friction, its encoder) is a body of its own, joined to the arm by a
//     spring and a damper. The arm plant then has neither the rotor nor the
//     friction (arms_only()).
// The current measurement's filter belongs to the drive, not to the plant
// (CurrentFilter below).
#pragma once

#include <array>
#include <memory>
#include <string>

#include "delta/plant.hpp"
#include "delta/robot_description.hpp"

namespace delta {

// Whether any joint's drive train is other than rigid and ideal.
bool has_drive_train_effects(const RobotDescription& d);

// The robot as its arm plant sees it: an elastic joint's arm side is a
// bare hinge (the rotor's inertia, the friction and the rest of the drive
// train act on the motor side).
RobotDescription arms_only(const RobotDescription& d);

class DriveTrainPlant final : public Plant {
 public:
  // arms: the plant of arms_only(d), at rest. The motors start where the
  // arms are, their springs relaxed, unless place() says otherwise.
  DriveTrainPlant(std::unique_ptr<Plant> arms, const std::array<JointDrive, 3>& joints);

  // tau_Nm: the torque each drive commands, in the drive's nominal units.
  PlantStatus step(const Joint3& tau_Nm, double dt_s) override;
  void stop() override;
  // What the drives' encoders see: the motor side of an elastic gearbox
  // (in joint units: motor angle / gear ratio), else the arm.
  JointState state() const override;
  JointState arm_state() const override { return arms_->state(); }
  bool set_platform_force(const std::array<double, 3>& force_N) override {
    return arms_->set_platform_force(force_N);
  }
  const std::string& fault() const override;

  // Puts the motors where the arms at state `arm` (which the arm plant is
  // already in) hold the gear torques `gear_Nm` through their springs
  // (rigid gearboxes: nothing to place).
  void place_motors(const JointState& arm, const Joint3& gear_Nm);
  // The torque each gearbox passes to its arm at the current state.
  Joint3 gear_torque_Nm() const;
  bool elastic() const { return elastic_; }

  // The largest motor sub-step for an elastic joint: a fraction of its
  // period against the spring (rotor inertia and stiffness).
  double motor_step_s() const { return motor_step_s_; }

  // The arm plant's largest step under an elastic gearbox: its resonance
  // against the arms' inertia is then resolved to a fraction of a period.
  static constexpr double kArmStepElastic_s = 2.5e-4;

 private:
  PlantStatus step_rigid(const Joint3& tau_Nm, double dt_s);
  PlantStatus step_elastic(const Joint3& tau_Nm, double dt_s);
  // One motor sub-step of h against the arm at qa, qad (spring and damper
  // and friction implicit in the new velocity); returns the gear torque.
  double advance_motor(unsigned j, double tau_applied_Nm, double qa_rad, double qad_rad_s,
                       double h_s);
  double cogging_Nm(unsigned j, double motor_side_rad) const;

  std::unique_ptr<Plant> arms_;
  std::array<JointDrive, 3> joints_;
  bool elastic_{false};
  double motor_step_s_{0.0};
  // The motor side of an elastic gearbox, in joint units.
  Joint3 motor_q_rad_{}, motor_qd_rad_s_{}, motor_qdd_rad_s2_{};
  std::string fault_;
};

class MujocoPlant;
struct MujocoSettings;

// A robot description's multibody robot as the drives see it: the MuJoCo
// plant of its arms, with its drive train around it where it has one.
class MultibodyRobot final : public Plant {
 public:
  MultibodyRobot(const RobotDescription& d, const Joint3& q0_rad, const MujocoSettings& settings);
  ~MultibodyRobot() override;

  PlantStatus step(const Joint3& tau_Nm, double dt_s) override {
    return outer().step(tau_Nm, dt_s);
  }
  void stop() override { outer().stop(); }
  JointState state() const override { return outer().state(); }
  JointState arm_state() const override { return outer().arm_state(); }
  const std::string& fault() const override { return outer().fault(); }
  bool set_platform_force(const std::array<double, 3>& force_N) override {
    return outer().set_platform_force(force_N);
  }

  // The arms at state s, the motors where their springs carry the torques
  // that move the arms so (the arms' inverse dynamics at s).
  void place(const JointState& s);
  const DriveTrainPlant* drive_train() const { return drive_train_.get(); }

 private:
  Plant& outer();
  const Plant& outer() const;
  MujocoPlant* arms_{nullptr};  // owned by drive_train_ or by own_arms_
  std::unique_ptr<MujocoPlant> own_arms_;
  std::unique_ptr<DriveTrainPlant> drive_train_;
};

// A first-order filter on a drive's current (its torque) measurement:
// the reported value lags the true one with time constant tau_s (0: none).
class CurrentFilter {
 public:
  explicit CurrentFilter(double time_constant_s = 0.0) : time_constant_s_(time_constant_s) {}
  // The reported value after dt_s more of the true value `now` (held over
  // dt_s, the exact response of the first-order lag).
  double update(double now, double dt_s);
  double value() const { return value_; }
  void reset(double v) {
    value_ = v;
    started_ = true;
  }

 private:
  double time_constant_s_;
  double value_{0.0};
  bool started_{false};
};

}  // namespace delta
