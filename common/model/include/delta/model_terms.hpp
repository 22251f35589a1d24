// The physical parameters of the identification models `delta` and
// `lumped` (docs/model.md), written once: their names and units as
// `host_id fit` reports them, the basis term each multiplies, and where its
// value sits in HighFidelityParameters. The host's regressor and every
// reader of a saved result (the controller's feed_forward.model) use it.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "delta/dynamics.hpp"

namespace delta {

// How a physical parameter is shared between the joints.
enum class TermSharing {
  kArm,    // one per arm with --per-joint, else one for all three
  kJoint,  // one per joint always (friction, offsets)
  kRobot,  // one for the robot (the platform's)
};

struct ModelTerm {
  const char* name;
  const char* unit;
  bool nonnegative;
  const char* meaning;
  TermSharing sharing;
  Joint3 DynamicsBasis::*basis;  // nullptr: the constant 1
  Joint3 HighFidelityParameters::*joint_value;
  double HighFidelityParameters::*robot_value;
  // A second place the same value goes (the lumped model's one platform
  // mass is both the inertial and the weight mass); nullptr: none.
  double HighFidelityParameters::*robot_value_too;
};

// The terms of the physical model `name` ("delta" or "lumped"; empty for
// any other), with the Stribeck term and the torque offsets where asked.
std::vector<ModelTerm> physical_model_terms(std::string_view name, bool stribeck, bool offsets);

// Whether a term has one value per joint (names end in _1, _2, _3).
constexpr bool term_per_joint(const ModelTerm& t, bool per_joint_arms) {
  return t.sharing == TermSharing::kJoint || (t.sharing == TermSharing::kArm && per_joint_arms);
}

// The parameter's name for joint j (0-based) where per joint, else its name.
std::string term_parameter_name(const ModelTerm& t, bool per_joint, unsigned joint);

}  // namespace delta
