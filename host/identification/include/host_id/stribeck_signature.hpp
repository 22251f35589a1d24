// The Stribeck signature in a fit's residual (docs/trust.md): friction
// that is higher at low speed than the smoothed Coulomb term, falling off
// within a few tenths of a rad/s. A model without a Stribeck term hides it
// in the viscous and Coulomb friction, biased; its residual keeps the
// rest. Each joint's Stribeck term exp(-(qd/vs)^2) tanh(qd/w) is added to
// the fitted columns for a few vs, the rows taken as the motion spread
// takes them (every step-th), and the one that lowers the model's error
// most is reported where it lowers it by more than kStribeckDrop with a
// Stribeck friction on every joint of at least kStribeckJointShare of the
// largest one's.
#pragma once

#include <cstddef>
#include <optional>

#include "host_id/regression.hpp"

namespace host_id {

inline constexpr double kStribeckDrop = 0.05;       // of the torque RMSE
inline constexpr double kStribeckJointShare = 0.2;  // of the largest joint's friction

struct StribeckSignature {
  double velocity_rad_s{0};  // the vs that explains most
  double error_drop{0};      // the torque RMSE's fall with it, a fraction
};

// `first_rows` of `r` are the fit's equations; w the model's Coulomb
// smoothing.
std::optional<StribeckSignature> stribeck_signature(const Regression& r, std::size_t first_rows,
                                                    double coulomb_smoothing_rad_s,
                                                    std::size_t step);

}  // namespace host_id
