// The collision detector's thresholds from a fit's own residual
// (docs/safety.md), derived where the controller runs the fitted model as
// it is (delta or lumped, with the drive train's gains and load friction;
// not elastic).
//
// The controller filters each joint's residual, measured minus model
// torque, over kCollisionFilterTicks ticks (fw::CollisionConfig) and
// compares it with base + per_speed |qd| + per_acceleration |qdd|. On the
// fitted log the same filter over its samples (a sample a tick) gives the
// residual's peak P_j. The fit's torque is low-passed (its cut-off), the
// controller's is not: P_j adds the filtered noise the cut-off removed,
// its expected peak over the log's n samples, sqrt(2 ln n) times its
// standard deviation after the controller's filter (the noise's from the
// measured and filtered RMSE). The thresholds are
//   base_j = m P_j,  per_speed_j = m P_j / qd_max_j,
//   per_acceleration_j = m P_j / qdd_max_j,
// with m = kCollisionMargin and the fit's largest |qd|, |qdd| of the joint:
// within the fitted motion a threshold is m to 3m times the residual's
// peak, and beyond it grows with how far beyond the motion goes, as the
// model's error does where it extrapolates.
#pragma once

#include <array>
#include <optional>
#include <string>

#include "delta/identified_model.hpp"
#include "host_id/model.hpp"
#include "host_id/motion_ranges.hpp"

namespace host_id {

struct Prediction;  // identify.hpp
struct LogRmse;     // identify.hpp

inline constexpr double kCollisionMargin = 2.0;
inline constexpr unsigned kCollisionFilterTicks = 4;  // fw::CollisionConfig's 2^filter_shift

struct CollisionThresholdFit {
  delta::CollisionThresholds thresholds;
  std::array<double, 3> peak_residual_Nm{};  // the filtered residual's, on the fit log
};

// The controller's filtered residual's peak per joint over a log's
// prediction (in time order; the filter starts again after a gap of more
// than 1.5 steps), on torques as the prediction has them.
std::array<double, 3> filtered_residual_peak(const Prediction& p);

// The thresholds from the fitted log's prediction and its RMSE and motion
// ranges.
CollisionThresholdFit collision_thresholds_from(const Prediction& fitted, const LogRmse& fit);

// Why the thresholds cannot be derived: "" where they can, else why (a
// model the controller does not run, an elastic one whose arm-side states
// are not the controller's).
std::string collision_thresholds_unavailable(const ModelOptions& model);

}  // namespace host_id
