// The multibody delta, built with MuJoCo from a robot description at run
// time, in memory (docs/robot-description.md):
//   - each upper arm a body on a hinge about its motor axis, with the drive's
//     armature; the motor torque and the joint's smooth friction act on it;
//   - each forearm two rod bodies, each on a ball joint at the elbow, held to
//     the platform by a `connect` equality at its other end;
//   - the platform (and payload) a body on a free joint.
// Contacts are off; the integrator is RK4 with the Newton constraint solver
// and stiff equality settings, so that the closed chains stay closed (the
// largest violation over a run is kept: max_constraint_violation_m()).
#pragma once

#include <array>
#include <string>

#include "delta/plant.hpp"
#include "delta/robot_description.hpp"

struct mjModel_;
struct mjData_;

namespace delta {

// How MuJoCo integrates the robot: its integrator, the largest step, and
// the equality constraints' time constant, twice the step (as small as
// MuJoCo allows: the stiffer the constraint, the closer the chains stay
// closed).
enum class MujocoIntegrator { kEuler, kRk4 };
struct MujocoSettings {
  MujocoIntegrator integrator{MujocoIntegrator::kEuler};
  double max_step_s{5e-4};
};

// The longest semi-implicit Euler step the plant is tested at: there too,
// halving the step changes the torques that follow a path by under 0.1 % of
// their RMS, and unforced frictionless motion keeps its energy to 2 % of
// the kinetic energy over 1 s (1 % at the default 0.5 ms). The emulator
// runs at it: a lock-step run in the software-emulated HIL VM pays for
// every step. `simulate` keeps the finer default.
inline constexpr double kMujocoCoarsestStep_s = 1e-3;

// The MuJoCo model (MJCF) of a robot, assembled in its home pose (all arms
// horizontal). Exposed for tests and for users who want to look at it.
std::string mujoco_model_xml(const RobotDescription& d, const MujocoSettings& settings = {});

class MujocoPlant final : public Plant {
 public:
  // The robot at rest at q0 (which must be assembled: InputError if not).
  // Each step() is cut into equal MuJoCo steps of at most
  // settings.max_step_s.
  MujocoPlant(const RobotDescription& d, const Joint3& q0_rad, MujocoSettings settings = {});
  ~MujocoPlant() override;
  MujocoPlant(const MujocoPlant&) = delete;
  MujocoPlant& operator=(const MujocoPlant&) = delete;

  PlantStatus step(const Joint3& tau_Nm, double dt_s) override;
  void stop() override;
  JointState state() const override;
  const std::string& fault() const override { return fault_; }
  bool set_platform_force(const std::array<double, 3>& force_N) override {
    platform_force_N_ = force_N;
    return true;
  }

  // Puts the robot at the joint state s: every body where the joint angles
  // put it, moving as qd and qdd move it (the closed chains closed).
  // Clears a fault. InputError where q has no forward kinematics.
  void place(const JointState& s);
  // The joint torques that give the state s (the closed-chain inverse
  // dynamics of the multibody model, friction included): tau = G^T f, with
  // f the open tree's inverse dynamics and G the map from joint velocities
  // to the tree's velocities (both by central differences of assembled
  // poses).
  Joint3 inverse_dynamics(const JointState& s);
  // Kinetic plus potential energy [J] at the current state.
  double total_energy_J();
  // The largest distance between a rod's end and its platform joint seen at
  // the end of any step() so far [m]. Beyond kMaxViolation_m the plant
  // faults.
  double max_constraint_violation_m() const { return max_violation_m_; }
  static constexpr double kMaxViolation_m = 1e-3;
  double time_s() const { return time_s_; }

 private:
  // The tree's positions for joint angles q (rods and platform assembled);
  // false where q has no forward kinematics.
  bool assemble(const Joint3& q, double* qpos) const;
  // Tree velocities and accelerations along q + qd s + qdd s^2/2 at s = 0.
  void tree_motion(const JointState& s, double* qvel, double* qacc);
  double constraint_violation_m();
  void set_fault(const std::string& why);

  RobotDescription robot_;
  mjModel_* model_{nullptr};
  mjData_* data_{nullptr};
  mjData_* scratch_{nullptr};  // inverse dynamics, energy: never the running state
  int hinge_qpos_[3]{}, hinge_dof_[3]{};
  int ball_qpos_[6]{};
  int rod_body_[6]{};
  int free_qpos_{0};
  int platform_body_{0};
  Vec3<double> rod_home_{};                        // a rod's direction at home in its arm's frame
  std::array<Vec3<double>, 6> platform_anchor_{};  // rod ends, platform frame
  MujocoSettings settings_;
  double max_violation_m_{0.0};
  double time_s_{0.0};
  Joint3 last_qdd_{};
  std::string fault_;
  std::array<double, 3> platform_force_N_{};
};

}  // namespace delta
