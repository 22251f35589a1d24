// The range of a log's motion (its filtered states): what a fit was
// excited over, and what a prediction of another log asks of it. Beyond
// it a model extrapolates: an effect the excitation never showed (the
// Stribeck dip at speeds it did not reach, the gearbox's twist at
// accelerations it did not make) is not in the fit.
#pragma once

#include <array>
#include <ostream>
#include <string>
#include <vector>

#include "delta/dynamics.hpp"

namespace host_id {

struct MotionRanges {
  bool known{false};
  std::array<double, 3> q_min_rad{}, q_max_rad{};
  std::array<double, 3> qd_max_rad_s{};    // of |qd|
  std::array<double, 3> qdd_max_rad_s2{};  // of |qdd|
};

MotionRanges ranges_of(const std::vector<delta::JointState>& states);

// A log goes beyond the fit's range where an angle leaves the fitted span
// widened by kAngleMargin of it at each end, a speed exceeds the fitted
// maximum kSpeedRatio times, or an acceleration kAccelerationRatio times:
// clear extrapolation (the friction's shape is a function of speed; the
// inertia's terms are linear in the acceleration, so it takes more).
// Another path over much the same motion (docs/examples/path2.csv against
// path1.csv: speeds 1.5 times, accelerations 2 times, angles 21 % of the
// span beyond) is not flagged.
inline constexpr double kAngleMargin = 0.5;
inline constexpr double kSpeedRatio = 2.0;
inline constexpr double kAccelerationRatio = 3.0;

// "" where `log` stays within `fitted` (or either is unknown); else each
// joint and quantity that goes beyond, with both ranges: "joint 1 speed up
// to 3.1 rad/s against 1.0 rad/s; ...".
std::string beyond(const MotionRanges& fitted, const MotionRanges& log);

// The warning for a log that goes beyond what `fitted_name` was fitted on,
// to err; nothing where it stays within.
void warn_beyond(std::ostream& err, const std::string& log_name, const std::string& fitted_name,
                 const MotionRanges& fitted, const MotionRanges& log);

}  // namespace host_id
