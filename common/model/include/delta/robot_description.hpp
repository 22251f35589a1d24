// A delta robot as a multibody system: geometry, bodies and drive side, read
// from a robot description file (docs/robot-description.md). The multibody
// plant (common/plant) is built from it, and so is the "truth" that
// identification is measured against: the lumped model's parameters and
// those of the higher-fidelity model, each derived in docs/model.md.
//
// Frames: the arm frame of chain i has its origin on the motor axis, x from
// the motor axis towards the elbow, y along the motor axis (so that a
// positive rotation about y turns the arm down, as positive theta does) and
// z up when theta = 0. The platform frame is the base frame's orientation at
// the platform centre.
#pragma once

#include <array>
#include <optional>
#include <string>

#include "delta/dynamics.hpp"
#include "delta/geometry.hpp"
#include "delta/vec3.hpp"

namespace delta {

// A symmetric inertia tensor about a body's centre of mass, in its frame.
struct InertiaTensor {
  double xx_kg_m2{}, yy_kg_m2{}, zz_kg_m2{};
  double xy_kg_m2{}, xz_kg_m2{}, yz_kg_m2{};
};

struct UpperArmBody {
  double mass_kg{};
  Vec3<double> com_m{};  // in the arm frame; z < 0 is below the arm line
  InertiaTensor inertia{};
};

// One rod of a forearm's parallelogram: a tube between two ball centres
// forearm_length_m apart, with a ball cup at each end (point masses).
struct ForearmRod {
  double tube_mass_kg{};
  double tube_radius_m{};  // thin-walled: its inertia about its own axis
  double elbow_cup_mass_kg{};
  double platform_cup_mass_kg{};
};

// A point-like mass that moves with the platform (it only translates, so
// its inertia plays no part).
struct PlatformMass {
  double mass_kg{};
  Vec3<double> com_m{};  // in the platform frame
};

// The drive side of one joint, at the joint (after the gearbox).
struct JointDrive {
  double rotor_inertia_kg_m2{};  // at the motor
  double gear_ratio{1.0};
  double viscous_friction_Nm_s_per_rad{};
  // Smooth friction: (coulomb + stribeck exp(-(qd/stribeck_velocity)^2))
  // tanh(qd / friction_smoothing); stribeck = 0 for none.
  double coulomb_friction_Nm{};
  double stribeck_friction_Nm{};
  double stribeck_velocity_rad_s{0.1};
  double friction_smoothing_rad_s{0.02};
  // What the rotor adds to the joint's inertia: rotor inertia * ratio^2.
  double armature_kg_m2() const { return rotor_inertia_kg_m2 * gear_ratio * gear_ratio; }

  // The drive train as it is (docs/robot-description.md, "The drive
  // train"); each default is today's rigid, ideal drive.
  // The gearbox as a spring between the motor (its encoder, its inertia
  // and the friction above act there) and the arm; 0: rigid.
  double gearbox_stiffness_Nm_per_rad{0.0};
  double gearbox_damping_Nm_s_per_rad{0.0};
  // The motor's actual torque constant over the nominal one the drive
  // converts with: the torque applied and the torque reported are both
  // nominal constant * current, the arm gets this ratio times it.
  double torque_constant_ratio{1.0};
  // The drive reports its current through a first-order filter; 0: none.
  double current_filter_time_constant_s{0.0};
  // Gear friction that grows with the torque the gear carries:
  // coefficient * |torque|, opposing the motion like the Coulomb term.
  double load_friction_coefficient{0.0};
  // Cogging: amplitude * sin(periods * motor angle) at the joint.
  double cogging_amplitude_Nm{0.0};
  double cogging_periods_per_motor_rev{0.0};

  bool elastic() const { return gearbox_stiffness_Nm_per_rad > 0.0; }
};

// The controller's motion limits for this robot (its limits.* and
// gains.max_torque_Nm, docs/firmware.md), where the description gives
// them: delta_fw's `robot = FILE` takes them, `host_id design` designs
// within them and `host_id simulate` checks its paths against them.
struct RobotLimits {
  std::optional<double> min_rad, max_rad;
  std::optional<double> max_velocity_rad_s, max_acceleration_rad_s2;
  std::optional<double> max_torque_Nm;  // joint torque
  bool any() const {
    return min_rad || max_rad || max_velocity_rad_s || max_acceleration_rad_s2 || max_torque_Nm;
  }
};

struct RobotDescription {
  std::string name{"default-delta"};
  Geometry geometry{kDefaultGeometry};
  double rod_spacing_m{0.05};  // between the two rods of a forearm
  double gravity_m_s2{9.81};
  UpperArmBody upper_arm{};
  // Arms that differ, as manufactured arms do ("upper_arms" in the file):
  // arm i's body where given, else upper_arm.
  std::array<std::optional<UpperArmBody>, 3> arm_bodies{};
  ForearmRod rod{};
  PlatformMass platform{};
  PlatformMass payload{};
  std::array<JointDrive, 3> joints{};
  RobotLimits limits{};

  const UpperArmBody& arm(unsigned i) const { return arm_bodies[i] ? *arm_bodies[i] : upper_arm; }
};

// The default robot (docs/examples/robot.json): the default geometry, with
// bodies whose lumped model is default_lumped_parameters() to within 0.2 %.
RobotDescription default_robot_description();

// Reads and validates a robot description file. InputError names the file
// and the key: a missing or unknown key, a value of the wrong type, a
// negative mass, an inertia that no body has (not positive definite, or
// breaking the triangle inequality), a robot that cannot be assembled.
RobotDescription read_robot_description(const std::string& path);

// The same checks on a description built in code; `where` prefixes each
// message (a file name).
void validate_robot_description(const RobotDescription& d, const std::string& where);

// The smooth friction torque of a joint at speed qd (it opposes the motion).
double joint_friction_Nm(const JointDrive& j, double qd_rad_s);

// How a forearm rod's mass enters the dynamics. For a rigid rod whose ends
// move with the elbow E and the platform joint P, the kinetic energy of its
// translation and tumbling is  1/2 A |v_E|^2 + B v_E.v_P + 1/2 C |v_P|^2,
// and its weight is carried as elbow_weight at E and platform_weight at P.
struct RodMassSplit {
  double a_kg{}, b_kg{}, c_kg{};
  double elbow_weight_kg{}, platform_weight_kg{};
};
RodMassSplit rod_mass_split(const ForearmRod& rod, double length_m);

// The lumped model that best stands for this robot (docs/model.md):
// each rod's weight split between elbow and platform (half the tube each,
// plus its cup), the arm's centre of mass on the arm line, the armature in
// the arm inertia, the friction's Coulomb level with the default smoothing.
LumpedParameters lumped_truth(const RobotDescription& d);

// The higher-fidelity model's parameters for this robot (docs/
// model.md), with the friction's shape (Stribeck excess and
// velocity, smoothing; those of joint 1 where the joints differ): exact for
// the multibody robot.
HighFidelityParameters high_fidelity_truth(const RobotDescription& d);

}  // namespace delta
