#include "host_id/torque_lag.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "host_id/identify.hpp"

namespace host_id {

namespace {

constexpr double kFirstShift = -2.0;  // samples
constexpr double kLastShift = 8.0;
constexpr std::size_t kMostSamples = 5000;  // taken evenly from a longer log

// The squared error, over every `step`-th sample whose neighbours back to
// `reach` samples are evenly spaced, of the logged torque against the
// model's delayed by `shift` samples (interpolated linearly).
struct ShiftedError {
  const Prediction& p;
  std::vector<std::size_t> rows;  // samples with `reach` even steps before and after
  double operator()(double shift) const {
    const auto whole = static_cast<std::ptrdiff_t>(std::floor(shift));
    const double part = shift - static_cast<double>(whole);
    double sum = 0.0;
    for (const std::size_t k : rows) {
      const auto a = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(k) - whole);
      for (unsigned j = 0; j < 3; ++j) {
        const auto& y = p.predicted_Nm[j];
        const double delayed = (1.0 - part) * y[a] + part * y[a - 1];
        const double e = p.measured_Nm[j][k] - delayed;
        sum += e * e;
      }
    }
    return sum;
  }
};

std::vector<std::size_t> even_rows(const Prediction& p) {
  const std::size_t n = p.t_s.size();
  const auto reach = static_cast<std::size_t>(std::max(-kFirstShift, kLastShift)) + 1;
  std::vector<std::size_t> rows;
  if (n < 4 * reach) return rows;
  const double dt = (p.t_s.back() - p.t_s.front()) / static_cast<double>(n - 1);
  const std::size_t step = std::max<std::size_t>(1, n / kMostSamples);
  for (std::size_t k = reach; k + reach < n; k += step) {
    const double span = p.t_s[k + reach] - p.t_s[k - reach];
    if (std::abs(span - 2.0 * static_cast<double>(reach) * dt) < 0.5 * dt) rows.push_back(k);
  }
  return rows;
}

}  // namespace

std::optional<TorqueLag> torque_lag(const Prediction& fitted) {
  ShiftedError error{fitted, even_rows(fitted)};
  if (error.rows.size() < 200) return std::nullopt;
  const double dt =
      (fitted.t_s.back() - fitted.t_s.front()) / static_cast<double>(fitted.t_s.size() - 1);
  // Whole samples first, then twentieths around the best.
  double best = 0.0, best_error = error(0.0);
  const double at_zero = best_error;
  for (double s = kFirstShift; s <= kLastShift; s += 1.0) {
    if (const double e = error(s); e < best_error) best = s, best_error = e;
  }
  const double centre = best;
  for (double s = centre - 0.5; s <= centre + 0.5; s += 0.05) {
    if (s < kFirstShift || s > kLastShift) continue;
    if (const double e = error(s); e < best_error) best = s, best_error = e;
  }
  if (!(at_zero > 0.0)) return std::nullopt;
  return TorqueLag{best * dt, 1.0 - std::sqrt(best_error / at_zero)};
}

}  // namespace host_id
