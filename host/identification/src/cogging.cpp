#include "host_id/cogging.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>

#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"

namespace host_id {

namespace {

// The search's highest n: a motor's 20 periods through a 50:1 gear.
constexpr double kMostSearchedPeriods = 1000.0;
constexpr double kLeastRangeRad = 0.05;
constexpr std::size_t kLeastSamples = 200;

// One joint's residual against its angle, at the track's samples.
struct JointResidual {
  std::vector<double> q_rad, residual_Nm;
  double slow_speed_rad_s{0};  // the lower quartile of |qd|
};

JointResidual residual_of(const Prediction& p, const AngleTrack& angles, unsigned j) {
  JointResidual out;
  std::vector<double> speeds;
  std::size_t k = 0;
  for (std::size_t i = 0; i < angles.t_s.size(); ++i) {
    const double t = angles.t_s[i];
    while (k < p.t_s.size() && p.t_s[k] < t - 1e-9) ++k;
    if (k == p.t_s.size()) break;
    if (std::abs(p.t_s[k] - t) > 1e-9) continue;  // trimmed, or in a gap
    out.q_rad.push_back(angles.q_rad[j][i]);
    out.residual_Nm.push_back(p.measured_Nm[j][k] - p.predicted_Nm[j][k]);
    speeds.push_back(std::abs(p.velocity_rad_s[j][k]));
  }
  if (!speeds.empty()) {
    auto quartile = speeds.begin() + static_cast<std::ptrdiff_t>(speeds.size() / 4);
    std::nth_element(speeds.begin(), quartile, speeds.end());
    out.slow_speed_rad_s = *quartile;
  }
  double mean = 0.0;
  for (const double r : out.residual_Nm) mean += r;
  mean /= std::max<double>(1.0, static_cast<double>(out.residual_Nm.size()));
  for (double& r : out.residual_Nm) r -= mean;
  return out;
}

// The residual's mean in bins of the angle (centres from the lowest),
// under a Hann window over the range: the mean, not the sum, so that the
// time a motion dwells at its turning points does not weigh (a sum's
// spectrum has the dwell's slowly falling side lobes); the window, so that
// the peak's own side lobes fall fast.
struct Bins {
  std::vector<double> centre_rad, mean_Nm;
};

Bins bins_of(const JointResidual& r, double lowest_rad, double width_rad, std::size_t count) {
  Bins b;
  std::vector<double> sums(count, 0.0);
  std::vector<std::size_t> counts(count, 0);
  for (std::size_t i = 0; i < r.q_rad.size(); ++i) {
    const auto m =
        std::min(count - 1, static_cast<std::size_t>((r.q_rad[i] - lowest_rad) / width_rad));
    sums[m] += r.residual_Nm[i];
    ++counts[m];
  }
  for (std::size_t m = 0; m < count; ++m) {
    if (counts[m] == 0) continue;
    const double x = (static_cast<double>(m) + 0.5) / static_cast<double>(count);
    const double hann = std::pow(std::sin(std::numbers::pi * x), 2);
    b.centre_rad.push_back((static_cast<double>(m) + 0.5) * width_rad);
    b.mean_Nm.push_back(hann * sums[m] / static_cast<double>(counts[m]));
  }
  return b;
}

// The power on the grid n0 + g step, g < count (each bin's phase turned
// a step at a time).
std::vector<double> spectrum(const Bins& b, double n0, double step, std::size_t count) {
  std::vector<std::complex<double>> z, turn;
  for (std::size_t m = 0; m < b.mean_Nm.size(); ++m) {
    z.push_back(b.mean_Nm[m] * std::polar(1.0, -n0 * b.centre_rad[m]));
    turn.push_back(std::polar(1.0, -step * b.centre_rad[m]));
  }
  std::vector<double> power(count);
  for (std::size_t g = 0; g < count; ++g) {
    std::complex<double> s{0.0, 0.0};
    for (std::size_t m = 0; m < z.size(); ++m) {
      s += z[m];
      z[m] *= turn[m];
    }
    power[g] = std::norm(s);
  }
  return power;
}

// The median of the powers from half n to twice n (on, upwards, until it
// has 8), n's own lobe (the Hann window's nulls, `lobe` either side) left
// out; 0 where fewer than 8.
double background(const std::vector<double>& power, double n0, double step, double n, double lobe) {
  std::vector<double> window;
  for (std::size_t k = 0; k < power.size(); ++k) {
    const double nk = n0 + step * static_cast<double>(k);
    if (nk < n / 2.0 || std::abs(nk - n) < lobe) continue;
    if (nk > 2.0 * n && window.size() >= 8) break;
    window.push_back(power[k]);
  }
  if (window.size() < 8) return 0.0;
  auto middle = window.begin() + static_cast<std::ptrdiff_t>(window.size() / 2);
  std::nth_element(window.begin(), middle, window.end());
  return *middle;
}

// The grid point whose power stands highest over its background, moved to
// the top of its peak, and that ratio. Only where half its n is on the
// grid's lower part (n at least sqrt(2) n0): the smooth errors' power is
// highest at the grid's bottom.
std::pair<std::size_t, double> highest_peak(const std::vector<double>& power, double n0,
                                            double step, double lobe) {
  std::pair<std::size_t, double> best{0, 0.0};
  for (std::size_t g = 0; g < power.size(); ++g) {
    const double n = n0 + step * static_cast<double>(g);
    if (n / std::numbers::sqrt2 < n0) continue;
    const double b = background(power, n0, step, n, lobe);
    if (b > 0.0 && power[g] / b > best.second) best = {g, power[g] / b};
  }
  std::size_t& g = best.first;
  while (g + 1 < power.size() && power[g + 1] > power[g]) ++g;
  while (g > 0 && power[g - 1] > power[g]) --g;
  // The ratio at the top, where it was found below it.
  const double b = background(power, n0, step, n0 + step * static_cast<double>(g), lobe);
  if (b > 0.0) best.second = std::max(best.second, power[g] / b);
  return best;
}

// The residual's sin(n q), cos(n q) component by least squares beside a
// cubic in q (the smooth errors, which would pull the peak otherwise):
// the squares it explains (the n that explains most is the cogging's; the
// amplitude's own largest is not), and its amplitude.
struct Component {
  double explained_Nm2{0};
  double amplitude_Nm{0};
};

Component component_at(const JointResidual& r, double n) {
  constexpr int kTerms = 6;
  Eigen::Matrix<double, kTerms, kTerms> gram = Eigen::Matrix<double, kTerms, kTerms>::Zero();
  Eigen::Matrix<double, kTerms, 1> right = Eigen::Matrix<double, kTerms, 1>::Zero();
  const auto [lo, hi] = std::minmax_element(r.q_rad.begin(), r.q_rad.end());
  const double mid = 0.5 * (*lo + *hi), half = std::max(1e-9, 0.5 * (*hi - *lo));
  Eigen::Matrix<double, kTerms, 1> x;
  for (std::size_t i = 0; i < r.q_rad.size(); ++i) {
    const double u = (r.q_rad[i] - mid) / half;
    x << std::sin(n * r.q_rad[i]), std::cos(n * r.q_rad[i]), 1.0, u, u * u, u * u * u;
    gram.selfadjointView<Eigen::Lower>().rankUpdate(x);
    right += x * r.residual_Nm[i];
  }
  const Eigen::LDLT<Eigen::Matrix<double, kTerms, kTerms>> ldlt(
      gram.selfadjointView<Eigen::Lower>());
  if (ldlt.info() != Eigen::Success) return {};
  const Eigen::Matrix<double, kTerms, 1> c = ldlt.solve(right);
  return {c.dot(right), std::hypot(c(0), c(1))};
}

double rms_of(const std::vector<double>& v) {
  double sum_sq = 0.0;
  for (const double e : v) sum_sq += e * e;
  return std::sqrt(sum_sq / static_cast<double>(std::max<std::size_t>(1, v.size())));
}

// The n within a grid step of n_grid whose component explains most, to a
// 64th of the step (two passes of 8ths), and that component.
std::pair<double, Component> refined(const JointResidual& r, double n_grid, double step) {
  double best_n = n_grid;
  Component best = component_at(r, n_grid);
  for (double reach = step; reach > step / 64.0; reach /= 8.0) {
    const double centre = best_n;
    for (int k = -8; k <= 8; ++k) {
      const double n = centre + reach * k / 8.0;
      if (const Component c = component_at(r, n); c.explained_Nm2 > best.explained_Nm2) {
        best_n = n, best = c;
      }
    }
  }
  return {best_n, best};
}

// One joint's peak: its n (0: none), amplitude and ratio; nullopt where the
// joint's motion cannot tell.
std::optional<std::array<double, 3>> joint_peak(const JointResidual& r, double cutoff_hz) {
  if (r.q_rad.size() < kLeastSamples) return std::nullopt;
  const auto [lo, hi] = std::minmax_element(r.q_rad.begin(), r.q_rad.end());
  const double span = *hi - *lo;
  if (!(span >= kLeastRangeRad)) return std::nullopt;
  double n_max = kMostSearchedPeriods;
  if (r.slow_speed_rad_s > 0.0) {
    n_max = std::min(n_max, 2.0 * std::numbers::pi * cutoff_hz / r.slow_speed_rad_s);
  }
  const double n_min = std::max(kMinCoggingPeriods, 4.0 * std::numbers::pi / span);
  const double step = std::numbers::pi / (2.0 * span);  // a quarter of a peak's width
  if (!(n_max > 2.0 * n_min + 16.0 * step)) return std::array<double, 3>{0.0, 0.0, 0.0};
  const double width = std::numbers::pi / (4.0 * n_max);  // 8 bins a period at n_max
  const auto count = static_cast<std::size_t>(span / width) + 1;
  const Bins b = bins_of(r, *lo, width, count);
  const auto grid = static_cast<std::size_t>((n_max - n_min) / step) + 1;
  const std::vector<double> power = spectrum(b, n_min, step, grid);
  const auto [g, ratio] = highest_peak(power, n_min, step, 4.0 * std::numbers::pi / span);
  if (ratio < kCoggingPeakRatio) return std::array<double, 3>{0.0, 0.0, ratio};
  // A peak that explains too little of the residual cannot lower the
  // held-out error enough to be taken: not cogging that matters. Judged
  // first on the grid (half a step off the peak loses under a fifth of
  // its amplitude), then on the peak.
  const double least = kLeastCoggingShare * std::numbers::sqrt2 * rms_of(r.residual_Nm);
  const double n_grid = n_min + step * static_cast<double>(g);
  if (component_at(r, n_grid).amplitude_Nm < 0.8 * least) {
    return std::array<double, 3>{0.0, 0.0, ratio};
  }
  const auto [n, c] = refined(r, n_grid, step);
  if (c.amplitude_Nm < least) return std::array<double, 3>{0.0, 0.0, ratio};
  return std::array<double, 3>{n, c.amplitude_Nm, ratio};
}

}  // namespace

AngleTrack angle_track(const DeltaLog& log, double cutoff_hz) {
  AngleTrack track;
  std::size_t stride = 1;
  if (log.size() > 1 && cutoff_hz > 0.0) {
    const double step_s = (log.t.back() - log.t.front()) / static_cast<double>(log.size() - 1);
    if (step_s > 0.0)
      stride = std::max<std::size_t>(1, static_cast<std::size_t>(1.0 / (4.0 * cutoff_hz * step_s)));
  }
  for (std::size_t i = 0; i < log.size(); i += stride) {
    track.t_s.push_back(log.t[i]);
    for (unsigned j = 0; j < 3; ++j) track.q_rad[j].push_back(log.q[j][i]);
  }
  return track;
}

std::optional<CoggingSearch> find_cogging(const Prediction& fitted, const AngleTrack& angles,
                                          double cutoff_hz) {
  CoggingSearch out;
  bool any = false;
  for (unsigned j = 0; j < 3; ++j) {
    const std::optional<std::array<double, 3>> peak =
        joint_peak(residual_of(fitted, angles, j), cutoff_hz);
    if (!peak) continue;
    any = true;
    out.periods_per_rev[j] = (*peak)[0];
    out.amplitude_Nm[j] = (*peak)[1];
    out.peak_ratio[j] = (*peak)[2];
  }
  if (!any) return std::nullopt;
  return out;
}

}  // namespace host_id
