// A model `host_id fit --out RESULT.json` saved (format host_id-result/1,
// docs/report.md), read as physical parameters: what the
// controller's feed_forward.model and `host_id model load` take. Only the
// physical models (delta, lumped) have them; paper14's coefficients do not.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "delta/dynamics.hpp"
#include "delta/geometry.hpp"

namespace delta {

// The collision detector's thresholds the fit derived from its own
// residual (docs/safety.md): per joint, base + per_speed |qd| +
// per_acceleration |qdd|.
struct CollisionThresholds {
  Joint3 base_Nm{};
  Joint3 per_speed_Nm_s_per_rad{};
  Joint3 per_acceleration_Nm_s2_per_rad{};
};

// The drive's torque for the model's y: y / (1 - gap_j - mu_j tanh(qd_j /
// w) sign y). gap is joint j's torque constant's gap to joint 1's (joint 1:
// 0), mu the gear's load friction.
struct DriveTrainTerms {
  Joint3 torque_gain_gap{};
  Joint3 load_friction{};
};

struct IdentifiedModel {
  std::string kind;  // "delta" or "lumped"
  bool per_joint{false};
  bool offsets{false};
  // The geometry it was fitted for; results saved before it was recorded
  // have none.
  std::optional<Geometry> geometry;
  HighFidelityParameters parameters{};
  std::uint32_t fit_id{0};  // CRC-32 of the file's bytes: which fit this is
  // The drive train's torque gains and load friction where the fit has them
  // (docs/model.md, "The drive train"; 0: none): the controller runs them.
  DriveTrainTerms drive_train{};
  // Each gearbox's compliance 1/K [rad/(N m)] where the model is elastic
  // (`host_id fit --elastic` or --gearbox-stiffness; docs/model.md); all 0:
  // rigid. The controller compensates the deflection with it.
  Joint3 gearbox_compliance_rad_per_Nm{};
  // The fit's cogging terms (docs/model.md, "Cogging"): each joint's
  // periods per revolution and amplitude; 0: none. The controller does not
  // run them: its feed-forward leaves them out, and the fit derived the
  // collision thresholds without them.
  Joint3 cogging_periods_per_rev{};
  Joint3 cogging_amplitude_Nm{};
  // None in results saved before they were derived, and for models the fit
  // derives none for (paper14; elastic, whose states are the arm's).
  std::optional<CollisionThresholds> collision_thresholds;
};

// Reads a saved result. Throws InputError naming the file and the key (and
// what to do) for anything else: not a result, paper14, a missing or
// non-numeric parameter.
IdentifiedModel read_identified_model(const std::string& path);

// What the controller leaves out of m (its cogging terms), to say where
// the model is loaded; "" where nothing.
std::string left_out_by_controller(const IdentifiedModel& m);

// The physical parameters of a model of `kind` from its parameters' values
// by name (`value` returns nullopt for a name it does not have: the error
// names it). Parameters that were not identifiable (null) count as 0, as
// `host_id predict` takes them.
HighFidelityParameters physical_parameters(
    const std::string& kind, bool per_joint, bool offsets, double coulomb_smoothing_rad_s,
    double stribeck_velocity_rad_s,
    const std::function<std::optional<double>(const std::string& name)>& value);

}  // namespace delta
