#include "host_id/motion_spread.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "host_id/parallel.hpp"

namespace host_id {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Rows {
  Eigen::MatrixXd x;  // weighted rows, columns scaled to unit norm
  Eigen::VectorXd y;
  Eigen::VectorXd column_norm;
};

Rows weighted_rows(const Equations& r, const std::array<double, 3>& joint_weights,
                   std::size_t step) {
  const std::size_t n = (r.rows() + step - 1) / step;
  Rows out;
  out.x.resize(static_cast<Eigen::Index>(n), r.psi.cols());
  out.y.resize(static_cast<Eigen::Index>(n));
  for (std::size_t k = 0; k < n; ++k) {
    const auto row = static_cast<Eigen::Index>(k * step);
    const double w = std::sqrt(joint_weights[r.joint[k * step]]);
    out.x.row(static_cast<Eigen::Index>(k)) = w * r.psi.row(row);
    out.y(static_cast<Eigen::Index>(k)) = w * r.tau(row);
  }
  out.column_norm = out.x.colwise().norm().transpose();
  for (Eigen::Index c = 0; c < out.column_norm.size(); ++c) {
    if (!(out.column_norm(c) > 0.0)) out.column_norm(c) = 1.0;
    out.x.col(c) /= out.column_norm(c);
  }
  return out;
}

using Bins = std::array<std::vector<Eigen::Index>, kSpreadBins>;

// Rows `ordered` cut into kSpreadBins bins of equal count, in order.
Bins cut(const std::vector<Eigen::Index>& ordered) {
  Bins bins;
  for (unsigned g = 0; g < kSpreadBins; ++g) {
    const auto first = static_cast<std::ptrdiff_t>(ordered.size() * g / kSpreadBins);
    const auto end = static_cast<std::ptrdiff_t>(ordered.size() * (g + 1) / kSpreadBins);
    bins[g].assign(ordered.begin() + first, ordered.begin() + end);
  }
  return bins;
}

// A bin's moments: X_g^T X_g (from its lower half) and X_g^T y_g.
void bin_moments(const Rows& rows, const std::vector<Eigen::Index>& bin, Eigen::MatrixXd& gram,
                 Eigen::VectorXd& rhs) {
  const Eigen::Index p = rows.x.cols();
  const Eigen::MatrixXd xg = rows.x(bin, Eigen::all);
  Eigen::MatrixXd lower = Eigen::MatrixXd::Zero(p, p);
  lower.selfadjointView<Eigen::Lower>().rankUpdate(xg.transpose());
  gram = lower.selfadjointView<Eigen::Lower>();
  rhs = xg.transpose() * rows.y(bin);
}

// The delete-a-bin jackknife variance of every (scaled) parameter; NaN
// where a bin is too small or cannot be left out. Where the bins hold
// every row, the last one's moments are the whole's less the others'.
Eigen::VectorXd jackknife_variance(const Rows& rows, const Eigen::MatrixXd& a,
                                   const Eigen::VectorXd& b, const Bins& bins) {
  const Eigen::Index p = rows.x.cols();
  std::size_t binned = 0;
  for (const auto& bin : bins) {
    if (bin.size() < static_cast<std::size_t>(p)) return Eigen::VectorXd::Constant(p, kNaN);
    binned += bin.size();
  }
  const bool all_rows = binned == static_cast<std::size_t>(rows.x.rows());
  std::array<Eigen::MatrixXd, kSpreadBins> gram;
  std::array<Eigen::VectorXd, kSpreadBins> rhs;
  for (unsigned g = 0; g + (all_rows ? 1 : 0) < kSpreadBins; ++g) {
    bin_moments(rows, bins[g], gram[g], rhs[g]);
  }
  if (all_rows) {
    gram.back() = a;
    rhs.back() = b;
    for (unsigned g = 0; g + 1 < kSpreadBins; ++g) {
      gram.back() -= gram[g];
      rhs.back() -= rhs[g];
    }
  }
  std::array<Eigen::VectorXd, kSpreadBins> estimate;
  for (unsigned g = 0; g < kSpreadBins; ++g) {
    const Eigen::LDLT<Eigen::MatrixXd> rest(a - gram[g]);
    if (rest.info() != Eigen::Success || !(rest.rcond() > 1e-12)) {
      return Eigen::VectorXd::Constant(p, kNaN);
    }
    estimate[g] = rest.solve(b - rhs[g]);
  }
  Eigen::VectorXd mean = Eigen::VectorXd::Zero(p);
  for (const Eigen::VectorXd& e : estimate) mean += e / kSpreadBins;
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(p);
  for (const Eigen::VectorXd& e : estimate) sum += (e - mean).cwiseAbs2();
  return sum * ((kSpreadBins - 1.0) / kSpreadBins);
}

// The rows where column c is not zero in kSpreadBins bins by its value
// (ties in time order).
Bins bins_by(const Rows& rows, Eigen::Index c) {
  std::vector<std::pair<double, Eigen::Index>> own;
  for (Eigen::Index i = 0; i < rows.x.rows(); ++i) {
    if (rows.x(i, c) != 0.0) own.emplace_back(rows.x(i, c), i);
  }
  std::vector<Eigen::Index> ordered;
  ordered.reserve(own.size());
  // Only the bins' edges need their place: each bin is one selection.
  for (unsigned g = 1; g < kSpreadBins; ++g) {
    const std::size_t edge = own.size() * g / kSpreadBins;
    std::nth_element(own.begin() + static_cast<std::ptrdiff_t>(own.size() * (g - 1) / kSpreadBins),
                     own.begin() + static_cast<std::ptrdiff_t>(edge), own.end());
  }
  for (const auto& v : own) ordered.push_back(v.second);
  return cut(ordered);
}

// The larger of a and b where b is a number.
void keep_larger(Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  for (Eigen::Index c = 0; c < a.size(); ++c) {
    if (std::isfinite(b(c))) a(c) = std::isfinite(a(c)) ? std::max(a(c), b(c)) : b(c);
  }
}

}  // namespace

MotionSpread motion_spread(const Equations& r, const std::array<double, 3>& joint_weights,
                           std::size_t step, unsigned threads) {
  step = std::max<std::size_t>(step, 1);
  const Rows rows = weighted_rows(r, joint_weights, step);
  const Eigen::MatrixXd a = rows.x.transpose() * rows.x;
  const Eigen::VectorXd b = rows.x.transpose() * rows.y;
  const Eigen::Index p = rows.x.cols();
  std::vector<Eigen::Index> in_time(static_cast<std::size_t>(rows.x.rows()));
  for (std::size_t i = 0; i < in_time.size(); ++i) in_time[i] = static_cast<Eigen::Index>(i);
  // Rows are in time order within the fast and the slow ones: order them
  // by their sample's time.
  std::stable_sort(in_time.begin(), in_time.end(), [&](Eigen::Index i, Eigen::Index k) {
    return r.sample[static_cast<std::size_t>(i) * step] <
           r.sample[static_cast<std::size_t>(k) * step];
  });
  // The partitions (time, then each column's values) are independent:
  // shared out over the threads, each into its own place.
  std::vector<Eigen::VectorXd> variance(static_cast<std::size_t>(p) + 1);
  run_tasks(
      variance.size(), workers_for(variance.size(), threads, 1), [&](std::size_t, std::size_t k) {
        variance[k] = jackknife_variance(
            rows, a, b, k == 0 ? cut(in_time) : bins_by(rows, static_cast<Eigen::Index>(k - 1)));
      });
  MotionSpread out;
  out.time_std_dev = variance[0];
  Eigen::VectorXd columns = Eigen::VectorXd::Constant(p, kNaN);
  for (std::size_t k = 1; k < variance.size(); ++k) keep_larger(columns, variance[k]);
  Eigen::VectorXd largest = columns;
  keep_larger(largest, out.time_std_dev);
  out.std_dev = largest.cwiseSqrt().cwiseQuotient(rows.column_norm);
  out.column_std_dev = columns.cwiseSqrt().cwiseQuotient(rows.column_norm);
  out.time_std_dev = out.time_std_dev.cwiseSqrt().cwiseQuotient(rows.column_norm);
  return out;
}

MotionSpread add_model_error(const Equations& r, std::size_t correlation_lags,
                             LeastSquaresResult& ls, unsigned threads) {
  const MotionSpread spread =
      motion_spread(r, ls.joint_weights, nyquist_step(correlation_lags), threads);
  ls.honest_std_dev = ls.std_dev;
  keep_larger(ls.honest_std_dev, spread.std_dev);
  return spread;
}

}  // namespace host_id
