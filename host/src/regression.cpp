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

Equations::Equations(const Regression& r) : Equations(r, r.rows()) {}

Equations::Equations(const Regression& r, std::size_t first_rows)
    : psi(r.psi.topRows(static_cast<Eigen::Index>(first_rows))),
      tau(r.tau.head(static_cast<Eigen::Index>(first_rows))),
      joint(r.joint.data(), first_rows),
      sample(r.sample.data(), first_rows),
      t_s(r.t_s) {}

std::array<std::size_t, 3> Equations::rows_per_joint() const {
  std::array<std::size_t, 3> n{};
  for (const unsigned char j : joint) ++n[j];
  return n;
}

namespace {

// Applies a permutation of rows (row i takes old row from[i]) to v in place.
template <class T>
void permute(std::vector<T>& v, const std::vector<std::size_t>& from, std::vector<T>& buffer) {
  buffer.resize(from.size());
  for (std::size_t i = 0; i < from.size(); ++i) buffer[i] = v[from[i]];
  std::swap(v, buffer);
}

}  // namespace

std::size_t fast_rows_first(Regression& r, double min_speed_rad_s) {
  std::vector<std::size_t> from;
  from.reserve(r.rows());
  for (std::size_t row = 0; row < r.rows(); ++row) {
    if (std::abs(r.velocity_rad_s[row]) >= min_speed_rad_s) from.push_back(row);
  }
  const std::size_t fast = from.size();
  if (fast == r.rows()) return fast;
  for (std::size_t row = 0; row < r.rows(); ++row) {
    if (std::abs(r.velocity_rad_s[row]) < min_speed_rad_s) from.push_back(row);
  }
  std::vector<double> column;
  for (Eigen::Index c = 0; c < r.psi.cols(); ++c) {
    column.assign(r.psi.col(c).data(), r.psi.col(c).data() + r.psi.rows());
    for (std::size_t i = 0; i < from.size(); ++i) {
      r.psi(static_cast<Eigen::Index>(i), c) = column[from[i]];
    }
  }
  column.assign(r.tau.data(), r.tau.data() + r.tau.size());
  for (std::size_t i = 0; i < from.size(); ++i)
    r.tau(static_cast<Eigen::Index>(i)) = column[from[i]];
  std::vector<double> speed_buffer;
  permute(r.velocity_rad_s, from, speed_buffer);
  std::vector<unsigned char> joint_buffer;
  permute(r.joint, from, joint_buffer);
  std::vector<std::size_t> sample_buffer;
  permute(r.sample, from, sample_buffer);
  return fast;
}

double direct_cost(const Equations& r, const Eigen::VectorXd& beta) {
  return (r.tau - r.psi * beta).squaredNorm() / static_cast<double>(r.tau.size());
}

QuadraticCost::QuadraticCost(const Equations& r, const Eigen::VectorXd& beta0)
    : beta0_(beta0),
      rows_(static_cast<double>(r.tau.size())),
      d_(beta0.size()),
      g_d_(beta0.size()) {
  const Eigen::VectorXd r0 = r.tau - r.psi * beta0;
  psi_t_psi_ = r.psi.transpose() * r.psi;
  psi_t_r0_ = r.psi.transpose() * r0;
  r0_t_r0_ = r0.squaredNorm();
}

double QuadraticCost::operator()(const Eigen::VectorXd& beta) const {
  d_.noalias() = beta - beta0_;
  g_d_.noalias() = psi_t_psi_.selfadjointView<Eigen::Upper>() * d_;
  return std::max(0.0, (r0_t_r0_ - 2.0 * d_.dot(psi_t_r0_) + d_.dot(g_d_)) / rows_);
}

std::array<double, 3> mean_square_per_joint(const Equations& r, const Eigen::VectorXd& e) {
  std::array<double, 3> sum{};
  for (std::size_t row = 0; row < r.rows(); ++row)
    sum[r.joint[row]] += std::pow(e(static_cast<Eigen::Index>(row)), 2);
  const std::array<std::size_t, 3> n = r.rows_per_joint();
  for (unsigned j = 0; j < 3; ++j) sum[j] = n[j] > 0 ? sum[j] / static_cast<double>(n[j]) : 0.0;
  return sum;
}

std::array<double, 3> rmse_per_joint(const Equations& r, const Eigen::VectorXd& beta) {
  std::array<double, 3> ms = mean_square_per_joint(r, r.tau - r.psi * beta);
  for (double& m : ms) m = std::sqrt(m);
  return ms;
}

void MeasuredMoments::reset(std::size_t parameters) {
  const auto p = static_cast<Eigen::Index>(parameters);
  for (unsigned j = 0; j < 3; ++j) {
    psi_t_psi[j] = Eigen::MatrixXd::Zero(p, p);
    psi_t_tau[j] = Eigen::VectorXd::Zero(p);
    tau_sq[j] = 0.0;
    rows[j] = 0;
  }
}

void MeasuredMoments::add(unsigned joint, const double* row, double tau) {
  Eigen::MatrixXd& g = psi_t_psi[joint];
  Eigen::VectorXd& h = psi_t_tau[joint];
  const Eigen::Index p = h.size();
  for (Eigen::Index a = 0; a < p; ++a) {
    if (row[a] == 0.0) continue;  // a joint's row is zero in the other joints' columns
    h(a) += row[a] * tau;
    for (Eigen::Index b = a; b < p; ++b) g(a, b) += row[a] * row[b];
  }
  tau_sq[joint] += tau * tau;
  ++rows[joint];
}

void MeasuredMoments::merge(const MeasuredMoments& other) {
  for (unsigned j = 0; j < 3; ++j) {
    psi_t_psi[j] += other.psi_t_psi[j];
    psi_t_tau[j] += other.psi_t_tau[j];
    tau_sq[j] += other.tau_sq[j];
    rows[j] += other.rows[j];
  }
}

std::array<double, 3> MeasuredMoments::rmse(const Eigen::VectorXd& beta) const {
  std::array<double, 3> out{};
  for (unsigned j = 0; j < 3; ++j) {
    if (rows[j] == 0) continue;
    const double sum = tau_sq[j] - 2.0 * beta.dot(psi_t_tau[j]) +
                       beta.dot(psi_t_psi[j].selfadjointView<Eigen::Upper>() * beta);
    out[j] = std::sqrt(std::max(0.0, sum) / static_cast<double>(rows[j]));
  }
  return out;
}

}  // namespace host_id
