// The logged torque's lag behind the motion (docs/trust.md): a drive
// reports its current through a filter (or a cycle late), so the logged
// torque is the true one delayed. Over the fit's own log the model's
// torque, shifted later by d, is compared with the logged one (on at most
// 5000 samples, evenly taken): the d that explains it best (to a
// twentieth of a sample, from -2 to +8 samples) and
// how much that shift lowers the torque error. A lag that lowers it by
// kTorqueLagDoubt or more matters at the log's bandwidth; below, it costs
// nothing there. It is the lag the fitted model leaves: the fit's inertias
// and viscous friction absorb part of the drive's (of a 3 ms current
// filter, 2.3 ms is left; of 0.5 ms, none), so it is a lower bound of the
// drive's delay.
#pragma once

#include <optional>

namespace host_id {

struct Prediction;  // identify.hpp

inline constexpr double kTorqueLagDoubt = 0.05;

struct TorqueLag {
  double lag_s{0};       // the logged torque's delay; negative: it leads
  double error_drop{0};  // the torque RMSE's fall with the shift, a fraction
};

// None for a log too short or too broken into segments to tell.
std::optional<TorqueLag> torque_lag(const Prediction& fitted);

}  // namespace host_id
