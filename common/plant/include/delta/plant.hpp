// The simulated robot that the emulated drives move and `host_id simulate`
// follows a path on: joint torques in, joint angles, velocities and
// accelerations out. Two plants stand behind this interface:
//   - LumpedPlant: the lumped model of delta/dynamics.hpp, integrated by RK4
//     (exactly the model `host_id fit --model lumped` estimates; for fast
//     unit tests);
//   - MujocoPlant (delta/mujoco_plant.hpp): a multibody delta built with
//     MuJoCo from a robot description, which no identification model
//     contains exactly.
// A plant never lies: a state that is not finite, that runs away or leaves
// the workspace is reported as a fault, and the plant stays stopped.
#pragma once

#include <array>
#include <string>

#include "delta/dynamics.hpp"

namespace delta {

enum class PlantStatus { kOk, kNoKinematics, kDiverged };

class Plant {
 public:
  virtual ~Plant() = default;
  // Advances by dt_s under the joint torques tau_Nm, held over the step.
  // After a fault the plant no longer moves and every step returns it.
  virtual PlantStatus step(const Joint3& tau_Nm, double dt_s) = 0;
  // The brakes hold the arms: every velocity becomes zero.
  virtual void stop() = 0;
  // The joint state at the current time as the drives' encoders see it
  // (qdd: the accelerations of the last step's start, or zero before the
  // first).
  virtual JointState state() const = 0;
  // The arms' own joint state: the same as state() but behind an elastic
  // gearbox, whose encoder sits on the motor.
  virtual JointState arm_state() const { return state(); }
  // Why the plant faulted; empty while it has not.
  virtual const std::string& fault() const = 0;
  // A force on the platform's centre (world frame, N) from the next step on,
  // until changed (a contact); false where the plant has no platform body
  // to put it on (the lumped plant).
  virtual bool set_platform_force(const std::array<double, 3>& /*force_N*/) { return false; }
};

// The largest joint speed a plant accepts before it calls the state
// diverged: far beyond any drive's, far below what a diverging integrator
// reaches.
inline constexpr double kPlantMaxSpeed_rad_s = 200.0;

// The same check for every plant: an empty string when the state is sane.
std::string check_plant_state(const JointState& s);

class LumpedPlant final : public Plant {
 public:
  LumpedPlant(const Geometry& geometry, const LumpedParameters& parameters, const Joint3& q0_rad);
  PlantStatus step(const Joint3& tau_Nm, double dt_s) override;
  void stop() override { state_.qd_rad_s = {}; }
  JointState state() const override { return state_; }
  const std::string& fault() const override { return fault_; }

 private:
  void set_fault(const JointState& before, const std::string& why);

  Geometry geometry_;
  LumpedParameters parameters_;
  JointState state_{};
  std::string fault_;
  double time_s_{0.0};
};

}  // namespace delta
