#include "delta/model_terms.hpp"

namespace delta {

namespace {

using B = DynamicsBasis;
using H = HighFidelityParameters;

const ModelTerm kArmInertia{"arm_inertia",
                            "kg m^2",
                            true,
                            "arm about the motor axis, with the reflected rotor and the forearms' "
                            "elbow share",
                            TermSharing::kArm,
                            &B::inertia,
                            &H::arm_inertia_kg_m2,
                            nullptr,
                            nullptr};
const ModelTerm kViscous{"viscous_friction",
                         "N m s/rad",
                         true,
                         "viscous friction at the joint",
                         TermSharing::kJoint,
                         &B::viscous,
                         &H::viscous_friction_Nm_s_per_rad,
                         nullptr,
                         nullptr};
const ModelTerm kCoulomb{"coulomb_friction",
                         "N m",
                         true,
                         "Coulomb friction at the joint (smoothed as tanh(qd / w))",
                         TermSharing::kJoint,
                         &B::coulomb,
                         &H::coulomb_friction_Nm,
                         nullptr,
                         nullptr};
const ModelTerm kStribeck{"stribeck_friction",
                          "N m",
                          true,
                          "Stribeck excess of the friction at rest, exp(-(qd / vs)^2) tanh(qd / w)",
                          TermSharing::kJoint,
                          &B::stribeck,
                          &H::stribeck_friction_Nm,
                          nullptr,
                          nullptr};
const ModelTerm kOffset{"torque_offset",
                        "N m",
                        false,
                        "constant torque offset of the joint's measurement",
                        TermSharing::kJoint,
                        nullptr,
                        &H::torque_offset_Nm,
                        nullptr,
                        nullptr};

std::vector<ModelTerm> lumped_terms() {
  return {
      kArmInertia,
      {"arm_gravity_moment", "N m", true, "gravity moment of an arm at theta = 0",
       TermSharing::kArm, &B::gravity, &H::arm_gravity_cos_Nm, nullptr, nullptr},
      {"platform_mass", "kg", true,
       "equivalent platform mass: platform, payload, forearms' platform share", TermSharing::kRobot,
       &B::platform, nullptr, &H::platform_weight_mass_kg, &H::platform_inertial_mass_kg},
      kViscous,
      kCoulomb};
}

std::vector<ModelTerm> delta_terms() {
  return {
      kArmInertia,
      {"arm_gravity_cos", "N m", true,
       "gravity moment of an arm at theta = 0 (its centre of mass along the arm line, the "
       "forearms' elbow weight)",
       TermSharing::kArm, &B::gravity, &H::arm_gravity_cos_Nm, nullptr, nullptr},
      {"arm_gravity_sin", "N m", false,
       "gravity moment of an arm at theta = 90 deg from its centre of mass below the arm line",
       TermSharing::kArm, &B::gravity_sin, &H::arm_gravity_sin_Nm, nullptr, nullptr},
      {"platform_inertial_mass", "kg", true,
       "the mass the platform's acceleration moves: platform, payload, forearms' share",
       TermSharing::kRobot, &B::platform_inertial, nullptr, &H::platform_inertial_mass_kg, nullptr},
      {"platform_weight_mass", "kg", true,
       "the weight carried at the platform: platform, payload, forearms' share",
       TermSharing::kRobot, &B::platform_weight, nullptr, &H::platform_weight_mass_kg, nullptr},
      {"forearm_coupling", "kg", true,
       "coupling of the forearm rods' elbow and platform ends (2 B per forearm)",
       TermSharing::kRobot, &B::coupling, nullptr, &H::forearm_coupling_kg, nullptr},
      kViscous,
      kCoulomb};
}

}  // namespace

std::vector<ModelTerm> physical_model_terms(std::string_view name, bool stribeck, bool offsets) {
  std::vector<ModelTerm> terms;
  if (name == "delta") terms = delta_terms();
  if (name == "lumped") terms = lumped_terms();
  if (terms.empty()) return terms;
  if (stribeck) terms.push_back(kStribeck);
  if (offsets) terms.push_back(kOffset);
  return terms;
}

std::string term_parameter_name(const ModelTerm& t, bool per_joint, unsigned joint) {
  if (!per_joint) return t.name;
  return std::string(t.name) + "_" + std::to_string(joint + 1);
}

}  // namespace delta
