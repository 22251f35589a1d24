#include "host_id/regression.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <sstream>
#include <thread>
#include <utility>
#include <vector>

#include "delta/input_error.hpp"
#include "host_id/parallel.hpp"
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
      t_s(r.t_s),
      joint_columns{r.joint_columns[0], r.joint_columns[1], r.joint_columns[2]},
      joint_columns_of(r.joint_columns_of) {}

std::array<std::size_t, 3> Equations::rows_per_joint() const {
  std::array<std::size_t, 3> n{};
  for (const unsigned char j : joint) ++n[j];
  return n;
}

namespace {

// residual_squares() over rows [start, end): the prediction Psi beta of
// the rows (Eigen reads each column in one long sequential run), then the
// squared residuals summed per joint into four interleaved sums
// each, so that consecutive rows do not wait on each other's addition.
void add_residual_squares(const Equations& r, std::size_t start, std::size_t end,
                          std::size_t first_rows, const Eigen::VectorXd& beta,
                          std::vector<double>& predicted, ResidualSquares& s) {
  constexpr std::size_t kWays = 4;
  const std::size_t n = end - start;
  predicted.resize(n);
  double* y = predicted.data();
  Eigen::Map<Eigen::VectorXd>(y, static_cast<Eigen::Index>(n)).noalias() =
      r.psi.middleRows(static_cast<Eigen::Index>(start), static_cast<Eigen::Index>(n)) * beta;
  const double* tau = r.tau.data() + start;
  for (std::size_t k = 0; k < n; ++k) y[k] = (tau[k] - y[k]) * (tau[k] - y[k]);
  std::array<double, 3 * kWays> first{}, rest{};  // [way * 3 + joint]
  const unsigned char* joint = r.joint.data() + start;
  const std::size_t split = std::clamp(first_rows, start, end) - start;
  for (std::size_t k = 0; k < split; ++k) first[(k % kWays) * 3 + joint[k]] += y[k];
  for (std::size_t k = split; k < n; ++k) rest[(k % kWays) * 3 + joint[k]] += y[k];
  for (std::size_t way = 0; way < kWays; ++way) {
    for (unsigned j = 0; j < 3; ++j) {
      s.first[j] += first[way * 3 + j];
      s.all[j] += first[way * 3 + j] + rest[way * 3 + j];
    }
  }
}

}  // namespace

ResidualSquares residual_squares(const Equations& r, std::size_t first_rows,
                                 const Eigen::VectorXd& beta, unsigned threads) {
  constexpr std::size_t kChunkRows = 16384;
  const std::size_t rows = r.rows();
  const std::size_t chunks = std::max<std::size_t>(1, (rows + kChunkRows - 1) / kChunkRows);
  std::vector<ResidualSquares> partial(chunks);
  const std::size_t workers = workers_for(chunks, threads, 2);
  std::vector<std::vector<double>> predicted(workers);  // one buffer per thread
  run_tasks(chunks, workers, [&](std::size_t worker, std::size_t chunk) {
    add_residual_squares(r, chunk * kChunkRows, std::min(rows, (chunk + 1) * kChunkRows),
                         first_rows, beta, predicted[worker], partial[chunk]);
  });
  ResidualSquares total;
  for (const ResidualSquares& s : partial) {
    for (unsigned j = 0; j < 3; ++j) {
      total.first[j] += s.first[j];
      total.all[j] += s.all[j];
    }
  }
  return total;
}

double direct_cost(const Equations& r, const Eigen::VectorXd& beta) {
  return direct_cost(r, beta, {1.0, 1.0, 1.0});
}

double direct_cost(const Equations& r, const Eigen::VectorXd& beta,
                   const std::array<double, 3>& joint_weights) {
  return residual_squares(r, r.rows(), beta).cost(joint_weights, r.rows());
}

double ResidualSquares::cost(const std::array<double, 3>& joint_weights,
                             std::size_t first_rows) const {
  double sum = 0.0;
  for (unsigned j = 0; j < 3; ++j) sum += joint_weights[j] * first[j];
  return sum / static_cast<double>(first_rows);
}

QuadraticCost::QuadraticCost(const Equations& r, const Eigen::VectorXd& beta0)
    : per_row_(1.0 / static_cast<double>(r.tau.size())) {
  const Eigen::VectorXd r0 = r.tau - r.psi * beta0;
  set(r.psi.transpose() * r.psi, r.psi.transpose() * r0, beta0);
  r0_t_r0_ = r0.squaredNorm();
}

QuadraticCost::QuadraticCost(const Eigen::MatrixXd& psi_t_psi, const Eigen::VectorXd& psi_t_tau,
                             const Eigen::VectorXd& beta0, double r0_t_r0, std::size_t rows)
    : r0_t_r0_(r0_t_r0), per_row_(1.0 / static_cast<double>(rows)) {
  set(psi_t_psi, psi_t_tau - psi_t_psi * beta0, beta0);
}

void QuadraticCost::set(const Eigen::MatrixXd& psi_t_psi, const Eigen::VectorXd& psi_t_r0,
                        const Eigen::VectorXd& beta0) {
  const auto p = static_cast<std::size_t>(beta0.size());
  beta0_.assign(beta0.data(), beta0.data() + p);
  psi_t_r0_.assign(psi_t_r0.data(), psi_t_r0.data() + p);
  half_.assign(p * p, 0.0);
  for (std::size_t j = 0; j < p; ++j) {
    for (std::size_t i = 0; i <= j; ++i) {
      const double g = psi_t_psi(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
      half_[j * p + i] = i == j ? 0.5 * g : g;
    }
  }
}

// d^T (G d - 2 b) for d = beta - beta0 from `half`, G's upper triangle with
// half its diagonal (H), so that d^T G d = 2 d^T H d: row by row,
// (H d)_i = sum over j >= i of H_ij d_j.
double QuadraticCost::at(const double* beta) const {
  const std::size_t p = beta0_.size();
  double quadratic = 0.0;
  for (std::size_t i = 0; i < p; ++i) {
    double h_d = 0.0;
    for (std::size_t j = i; j < p; ++j) h_d += half_[j * p + i] * (beta[j] - beta0_[j]);
    quadratic += (beta[i] - beta0_[i]) * (h_d - psi_t_r0_[i]);
  }
  return std::max(0.0, (r0_t_r0_ + 2.0 * quadratic) * per_row_);
}

// With beta = lower + S u (S the spans on the diagonal): d = S (u - u0)
// for u0 = S^-1 (beta0 - lower), so the triangle becomes S H S and
// Psi^T r0 becomes S Psi^T r0.
QuadraticCost QuadraticCost::over_box(const Eigen::VectorXd& lower,
                                      const Eigen::VectorXd& upper) const {
  const std::size_t p = beta0_.size();
  QuadraticCost u = *this;
  for (std::size_t i = 0; i < p; ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    const double span = upper(k) - lower(k);
    u.beta0_[i] = (beta0_[i] - lower(k)) / span;
    u.psi_t_r0_[i] *= span;
    for (std::size_t j = 0; j < p; ++j) {
      u.half_[j * p + i] *= span;
      u.half_[i * p + j] *= span;
    }
  }
  return u;
}

std::array<double, 3> rmse_per_joint(const Equations& r, const Eigen::VectorXd& beta) {
  return rmse_per_joint(r, residual_squares(r, r.rows(), beta));
}

std::array<double, 3> rmse_per_joint(const Equations& r, const ResidualSquares& squares) {
  const std::array<std::size_t, 3> n = r.rows_per_joint();
  std::array<double, 3> rms{};
  for (unsigned j = 0; j < 3; ++j) {
    rms[j] = n[j] > 0 ? std::sqrt(squares.all[j] / static_cast<double>(n[j])) : 0.0;
  }
  return rms;
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

void MeasuredMoments::add(
    unsigned joint,
    const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>& rows_as_columns,
    const Eigen::Map<const Eigen::VectorXd, 0, Eigen::InnerStride<3>>& tau) {
  psi_t_psi[joint].selfadjointView<Eigen::Upper>().rankUpdate(rows_as_columns);
  psi_t_tau[joint].noalias() += rows_as_columns * tau;
  tau_sq[joint] += tau.squaredNorm();
  rows[joint] += static_cast<std::size_t>(tau.size());
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
