#include "host_id/motion_ranges.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace host_id {

MotionRanges ranges_of(const std::vector<delta::JointState>& states) {
  MotionRanges r;
  if (states.empty()) return r;
  r.known = true;
  r.q_min_rad.fill(std::numeric_limits<double>::infinity());
  r.q_max_rad.fill(-std::numeric_limits<double>::infinity());
  for (const delta::JointState& s : states) {
    for (unsigned j = 0; j < 3; ++j) {
      r.q_min_rad[j] = std::min(r.q_min_rad[j], s.q_rad[j]);
      r.q_max_rad[j] = std::max(r.q_max_rad[j], s.q_rad[j]);
      r.qd_max_rad_s[j] = std::max(r.qd_max_rad_s[j], std::abs(s.qd_rad_s[j]));
      r.qdd_max_rad_s2[j] = std::max(r.qdd_max_rad_s2[j], std::abs(s.qdd_rad_s2[j]));
    }
  }
  return r;
}

std::string beyond(const MotionRanges& fitted, const MotionRanges& log) {
  if (!fitted.known || !log.known) return "";
  std::ostringstream m;
  m.precision(3);
  const auto add = [&m](unsigned j, const char* what) -> std::ostringstream& {
    if (m.tellp() > 0) m << "; ";
    m << "joint " << j + 1 << " " << what << " ";
    return m;
  };
  for (unsigned j = 0; j < 3; ++j) {
    const double margin = kAngleMargin * (fitted.q_max_rad[j] - fitted.q_min_rad[j]);
    if (log.q_min_rad[j] < fitted.q_min_rad[j] - margin ||
        log.q_max_rad[j] > fitted.q_max_rad[j] + margin) {
      add(j, "angle") << log.q_min_rad[j] << " to " << log.q_max_rad[j] << " rad against "
                      << fitted.q_min_rad[j] << " to " << fitted.q_max_rad[j];
    }
    if (log.qd_max_rad_s[j] > kSpeedRatio * fitted.qd_max_rad_s[j]) {
      add(j, "speed up to") << log.qd_max_rad_s[j] << " rad/s against " << fitted.qd_max_rad_s[j];
    }
    if (log.qdd_max_rad_s2[j] > kAccelerationRatio * fitted.qdd_max_rad_s2[j]) {
      add(j, "acceleration up to")
          << log.qdd_max_rad_s2[j] << " rad/s^2 against " << fitted.qdd_max_rad_s2[j];
    }
  }
  return m.str();
}

void warn_beyond(std::ostream& err, const std::string& log_name, const std::string& fitted_name,
                 const MotionRanges& fitted, const MotionRanges& log) {
  const std::string what = beyond(fitted, log);
  if (what.empty()) return;
  err << log_name << ": warning: this log goes beyond the motion the fit (" << fitted_name
      << ") was made on (" << what
      << "): the prediction there is extrapolation, and its error may hold effects the fit "
         "never saw; fit on a log that covers this motion (host_id design, "
         "docs/design-excitation.md)\n";
}

}  // namespace host_id
