// The controller's feed-forward torque at a reference state, one of
//   off      none: the PID alone;
//   nominal  I_nom qdd_ref - G_nom cos(q_ref) per joint, from two configured
//            numbers (the arm alone, the platform's share lumped in);
//   model    the identified model (delta/fixed/dynamics.hpp): arms,
//            platform through the closed chain, forearm coupling, friction
//            and offsets, with the parameters `host_id fit` reported.
#pragma once

#include <array>
#include <cstdint>

#include "delta/fixed/dynamics.hpp"

namespace fw {

using delta::KinematicsStatus;
using delta::fx::GeometryQ;
using delta::fx::Joint3Q12_19;
using delta::fx::ModelKind;
using delta::fx::ModelParametersQ;
using delta::fx::ModelQ;
using delta::fx::Q12_19;

enum class FeedForwardMode : std::uint8_t { kOff = 0, kNominal = 1, kModel = 2 };

constexpr const char* feed_forward_mode_name(FeedForwardMode m) {
  return m == FeedForwardMode::kOff ? "off" : m == FeedForwardMode::kNominal ? "nominal" : "model";
}

struct NominalDynamics {
  Q12_19 arm_inertia_kg_m2{Q12_19::from(0.0)};
  Q12_19 gravity_moment_Nm{Q12_19::from(0.0)};  // includes the platform's share
  friend constexpr bool operator==(const NominalDynamics&, const NominalDynamics&) = default;
};

struct FeedForwardConfig {
  FeedForwardMode mode{FeedForwardMode::kNominal};
  NominalDynamics nominal{};
  // Used in mode kModel: its kind must not be kNone, and it must have been
  // fitted for the controller's geometry.
  ModelQ model{};
  // Mode kModel with a model that has gearbox compliances: track the motor
  // past the arm's reference by the deflection (fw/deflection.hpp).
  bool deflection_compensation{true};
  friend constexpr bool operator==(const FeedForwardConfig&, const FeedForwardConfig&) = default;
};

// Whether the controller compensates the gearboxes' deflection with `f`.
constexpr bool compensates_deflection(const FeedForwardConfig& f) {
  if (f.mode != FeedForwardMode::kModel || !f.deflection_compensation) return false;
  for (const auto c : f.model.parameters.gearbox_compliance_rad_per_Nm) {
    if (c.raw() != 0) return true;
  }
  return false;
}

// The feed-forward torques at reference ref. kOk, or (model only) why the
// reference's pose has no kinematics; the torques are then zero.
KinematicsStatus feed_forward_torque(const FeedForwardConfig& config,
                                     const delta::fx::JointStateQ& ref, Joint3Q12_19& tau_Nm);

}  // namespace fw
