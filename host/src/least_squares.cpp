#include "host_id/least_squares.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "delta/input_error.hpp"

namespace host_id {

Regression weighted(const Regression& r, const std::array<double, 3>& w) {
  Regression out = r;
  for (Eigen::Index row = 0; row < out.tau.size(); ++row) {
    const double s = std::sqrt(w[out.joint[static_cast<std::size_t>(row)]]);
    out.psi.row(row) *= s;
    out.tau(row) *= s;
  }
  return out;
}

namespace {

// S of the covariance in the scaled coordinates, per joint: each joint's
// g = a e laid out by sample (zero where the joint has no equation), then
//   S += G^T H,  H = G smoothed by the Bartlett weights 1 - |l|/(L+1),
// which is the sum over lags in one product. The triangle is two boxes of
// L+1 samples, each a difference of running sums: O(n p) for H. Lags run
// over the sample index, across a gap between segments too (a few pairs).
Eigen::MatrixXd lagged_score_covariance(const Regression& r, const Eigen::MatrixXd& scaled,
                                        const Eigen::VectorXd& e, std::size_t lags) {
  const Eigen::Index p = scaled.cols();
  const auto n = static_cast<Eigen::Index>(r.samples());
  const auto l = std::min<Eigen::Index>(static_cast<Eigen::Index>(lags), n);
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(p, p);
  // L zero rows after the last sample, so that the boxes reaching past it
  // are whole.
  const Eigen::Index m = n + l;
  Eigen::MatrixXd g(m, p), sums(m + 1, p), box(m, p), h(m, p);
  for (unsigned char j = 0; j < 3; ++j) {
    g.setZero();
    for (std::size_t row = 0; row < r.rows(); ++row) {
      if (r.joint[row] != j) continue;
      const auto i = static_cast<Eigen::Index>(row);
      g.row(static_cast<Eigen::Index>(r.sample[row])) = scaled.row(i) * e(i);
    }
    if (l == 0) {
      s.noalias() += g.transpose() * g;
      continue;
    }
    // box_k = sum of g over [k - L, k]; h_k = sum of box over [k, k + L] / (L + 1).
    sums.row(0).setZero();
    for (Eigen::Index k = 0; k < m; ++k) sums.row(k + 1) = sums.row(k) + g.row(k);
    for (Eigen::Index k = 0; k < m; ++k)
      box.row(k) = sums.row(k + 1) - sums.row(std::max<Eigen::Index>(0, k - l));
    sums.row(0).setZero();
    for (Eigen::Index k = 0; k < m; ++k) sums.row(k + 1) = sums.row(k) + box.row(k);
    const double norm = 1.0 / static_cast<double>(l + 1);
    for (Eigen::Index k = 0; k < n; ++k)
      h.row(k) = (sums.row(std::min(m, k + l + 1)) - sums.row(k)) * norm;
    s.noalias() += g.topRows(n).transpose() * h.topRows(n);
  }
  // Symmetric in exact arithmetic; make it so in floating point.
  return 0.5 * (s + s.transpose());
}

LeastSquaresResult solve_ordinary(const Regression& r, const Model& model, LsSolver solver,
                                  const std::string& log_name, std::size_t lags) {
  const Eigen::Index p = r.psi.cols();
  const Eigen::Index rows = r.psi.rows();
  Eigen::VectorXd col_norm = r.psi.colwise().norm().transpose();
  for (Eigen::Index c = 0; c < p; ++c) {
    if (!(col_norm(c) > 0.0)) {
      throw delta::InputError(log_name + ": parameter '" +
                              model.parameters()[static_cast<unsigned>(c)].name +
                              "' is not excited at all by this log (its regressor column is zero)");
    }
  }
  const Eigen::MatrixXd scaled = r.psi * col_norm.cwiseInverse().asDiagonal();
  // Singular values of the scaled regressor: conditioning and rank.
  Eigen::BDCSVD<Eigen::MatrixXd> svd(scaled, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::VectorXd sv = svd.singularValues();
  const double tol = 1e-10 * sv(0);
  if (sv(p - 1) <= tol) {
    // The right singular vector of the smallest value names the mix of
    // parameters the data cannot separate.
    const Eigen::VectorXd v = svd.matrixV().col(p - 1);
    std::ostringstream s;
    s << log_name << ": the regressor is rank-deficient (smallest scaled singular value "
      << sv(p - 1) / sv(0) << " of the largest): this trajectory cannot tell apart";
    for (Eigen::Index c = 0; c < p; ++c) {
      if (std::abs(v(c)) > 0.2)
        s << " '" << model.parameters()[static_cast<unsigned>(c)].name << "'";
    }
    s << "; use a richer excitation or a model with fewer parameters";
    throw delta::InputError(s.str());
  }
  Eigen::VectorXd beta_scaled;
  if (solver == LsSolver::kSvd) {
    beta_scaled = svd.solve(r.tau);
  } else {
    beta_scaled = scaled.colPivHouseholderQr().solve(r.tau);
  }
  LeastSquaresResult out;
  out.beta = beta_scaled.cwiseQuotient(col_norm);
  const double rss = (r.tau - r.psi * out.beta).squaredNorm();
  out.cost = rss / static_cast<double>(rows);
  // (A^T A)^-1 = V Sigma^-2 V^T for the scaled regressor A = U Sigma V^T.
  const Eigen::MatrixXd vs = svd.matrixV() * sv.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd inv_ata = vs * vs.transpose();
  const Eigen::VectorXd e = r.tau - scaled * beta_scaled;
  const double dof = rows > p ? static_cast<double>(rows) / static_cast<double>(rows - p) : 0.0;
  const Eigen::MatrixXd cov_scaled =
      dof * inv_ata * lagged_score_covariance(r, scaled, e, lags) * inv_ata;
  out.std_dev = cov_scaled.diagonal().cwiseMax(0.0).cwiseSqrt().cwiseQuotient(col_norm);
  out.correlation_lags = lags;
  out.condition_number_scaled = sv(0) / sv(p - 1);
  Eigen::JacobiSVD<Eigen::MatrixXd> raw(r.psi.transpose() * r.psi);
  const Eigen::VectorXd ev = raw.singularValues();
  out.condition_number = std::sqrt(ev(0) / ev(p - 1));
  return out;
}

}  // namespace

std::size_t correlation_lags_for(double sample_rate_hz, double cutoff_hz) {
  if (!(sample_rate_hz > 0.0) || !(cutoff_hz > 0.0)) return 0;
  return static_cast<std::size_t>(std::ceil(2.0 * sample_rate_hz / cutoff_hz));
}

LeastSquaresResult solve_least_squares(const Regression& r, const Model& model, LsSolver solver,
                                       LsWeights weights, const std::string& log_name,
                                       std::size_t correlation_lags) {
  LeastSquaresResult ols = solve_ordinary(r, model, solver, log_name, correlation_lags);
  if (weights == LsWeights::kNone) return ols;
  const std::array<double, 3> var = mean_square_per_joint(r, r.tau - r.psi * ols.beta);
  std::array<double, 3> w{};
  for (unsigned j = 0; j < 3; ++j) w[j] = var[j] > 0.0 ? 1.0 / var[j] : 1.0;
  // Normalise so the weights average to one over the joints.
  const double mean_w = (w[0] + w[1] + w[2]) / 3.0;
  for (double& x : w) x /= mean_w;
  LeastSquaresResult wls =
      solve_ordinary(weighted(r, w), model, solver, log_name, correlation_lags);
  wls.joint_weights = w;
  return wls;
}

}  // namespace host_id
