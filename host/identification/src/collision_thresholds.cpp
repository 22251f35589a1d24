#include "host_id/collision_thresholds.hpp"

#include <algorithm>
#include <cmath>

#include "host_id/identify.hpp"

namespace host_id {

std::array<double, 3> filtered_residual_peak(const Prediction& p) {
  std::array<double, 3> peak{};
  const std::size_t n = p.t_s.size();
  if (n == 0) return peak;
  const double step = n > 1 ? (p.t_s.back() - p.t_s.front()) / static_cast<double>(n - 1) : 0.0;
  for (unsigned j = 0; j < 3; ++j) {
    double filtered = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      const double r = p.measured_Nm[j][k] - p.predicted_Nm[j][k];
      const bool restart = k == 0 || p.t_s[k] - p.t_s[k - 1] > 1.5 * step;
      filtered = restart ? r : filtered + (r - filtered) / kCollisionFilterTicks;
      peak[j] = std::max(peak[j], std::abs(filtered));
    }
  }
  return peak;
}

namespace {

// The expected peak, over n samples, of the measured torque's noise above
// the fit's cut-off once the controller's filter has passed it.
double noise_peak_Nm(double rmse_measured_Nm, double rmse_filtered_Nm, std::size_t n) {
  if (n < 2) return 0.0;
  const double noise_sq =
      std::max(0.0, rmse_measured_Nm * rmse_measured_Nm - rmse_filtered_Nm * rmse_filtered_Nm);
  const double a = 1.0 / kCollisionFilterTicks;  // r_f += a (r - r_f): white noise's gain
  return std::sqrt(2.0 * std::log(static_cast<double>(n))) * std::sqrt(noise_sq * a / (2.0 - a));
}

}  // namespace

CollisionThresholdFit collision_thresholds_from(const Prediction& fitted, const LogRmse& fit) {
  CollisionThresholdFit out;
  const std::array<double, 3> peak = filtered_residual_peak(fitted);
  delta::CollisionThresholds& t = out.thresholds;
  for (unsigned j = 0; j < 3; ++j) {
    out.peak_residual_Nm[j] = peak[j] + noise_peak_Nm(fit.rmse_measured_Nm[j],
                                                      fit.rmse_filtered_Nm[j], fitted.t_s.size());
    const double base = kCollisionMargin * out.peak_residual_Nm[j];
    t.base_Nm[j] = base;
    // A joint that never moved has no range to scale by: its threshold is
    // then the base alone.
    const MotionRanges& ranges = fit.ranges;
    t.per_speed_Nm_s_per_rad[j] =
        ranges.qd_max_rad_s[j] > 0.0 ? base / ranges.qd_max_rad_s[j] : 0.0;
    t.per_acceleration_Nm_s2_per_rad[j] =
        ranges.qdd_max_rad_s2[j] > 0.0 ? base / ranges.qdd_max_rad_s2[j] : 0.0;
  }
  return out;
}

std::string collision_thresholds_unavailable(const ModelOptions& model) {
  if (model.name != "delta" && model.name != "lumped") {
    return "the " + model.name + " model does not run on the controller";
  }
  if (model.elastic()) {
    return "none are derived for an elastic model (its residual is the arms', which the "
           "controller's motor encoders do not see): fit without --elastic and "
           "--gearbox-stiffness for a model with thresholds, or set collision.threshold_Nm";
  }
  return "";
}

}  // namespace host_id
