#include "host_id/regression.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <sstream>
#include <thread>
#include <vector>

#include "delta/input_error.hpp"
#include "host_id/signal.hpp"

namespace host_id {

std::array<std::size_t, 3> Regression::rows_per_joint() const {
  std::array<std::size_t, 3> n{};
  for (const unsigned char j : joint) ++n[j];
  return n;
}

Regression without_slow_rows(const Regression& r, double min_speed_rad_s) {
  std::vector<Eigen::Index> kept;
  kept.reserve(r.rows());
  for (std::size_t row = 0; row < r.rows(); ++row) {
    if (r.speed_rad_s[row] >= min_speed_rad_s) kept.push_back(static_cast<Eigen::Index>(row));
  }
  Regression out;
  out.t_s = r.t_s;
  out.psi = r.psi(kept, Eigen::all);
  out.tau = r.tau(kept);
  out.joint.reserve(kept.size());
  out.speed_rad_s.reserve(kept.size());
  out.sample.reserve(kept.size());
  for (const Eigen::Index row : kept) {
    const auto i = static_cast<std::size_t>(row);
    out.joint.push_back(r.joint[i]);
    out.speed_rad_s.push_back(r.speed_rad_s[i]);
    out.sample.push_back(r.sample[i]);
  }
  return out;
}

double direct_cost(const Regression& r, const Eigen::VectorXd& beta) {
  return (r.tau - r.psi * beta).squaredNorm() / static_cast<double>(r.tau.size());
}

QuadraticCost::QuadraticCost(const Regression& r, const Eigen::VectorXd& beta0)
    : beta0_(beta0), rows_(static_cast<double>(r.tau.size())) {
  const Eigen::VectorXd r0 = r.tau - r.psi * beta0;
  psi_t_psi_ = r.psi.transpose() * r.psi;
  psi_t_r0_ = r.psi.transpose() * r0;
  r0_t_r0_ = r0.squaredNorm();
}

double QuadraticCost::operator()(const Eigen::VectorXd& beta) const {
  const Eigen::VectorXd d = beta - beta0_;
  const double quad = d.dot(psi_t_psi_.selfadjointView<Eigen::Upper>() * d);
  return std::max(0.0, (r0_t_r0_ - 2.0 * d.dot(psi_t_r0_) + quad) / rows_);
}

std::array<double, 3> mean_square_per_joint(const Regression& r, const Eigen::VectorXd& e) {
  std::array<double, 3> sum{};
  for (std::size_t row = 0; row < r.rows(); ++row)
    sum[r.joint[row]] += std::pow(e(static_cast<Eigen::Index>(row)), 2);
  const std::array<std::size_t, 3> n = r.rows_per_joint();
  for (unsigned j = 0; j < 3; ++j) sum[j] = n[j] > 0 ? sum[j] / static_cast<double>(n[j]) : 0.0;
  return sum;
}

std::array<double, 3> rmse_per_joint(const Regression& r, const Eigen::VectorXd& beta) {
  std::array<double, 3> ms = mean_square_per_joint(r, r.tau - r.psi * beta);
  for (double& m : ms) m = std::sqrt(m);
  return ms;
}

}  // namespace host_id
