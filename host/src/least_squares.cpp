#include "host_id/least_squares.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "host_id/input_error.hpp"

namespace host_id {

Regression weighted(const Regression& r, const std::array<double, 3>& w) {
  Regression out = r;
  for (Eigen::Index row = 0; row < out.tau.size(); ++row) {
    const double s = std::sqrt(w[static_cast<unsigned>(row % 3)]);
    out.psi.row(row) *= s;
    out.tau(row) *= s;
  }
  return out;
}

namespace {

LeastSquaresResult solve_ordinary(const Regression& r, const Model& model, LsSolver solver,
                                  const std::string& log_name) {
  const Eigen::Index p = r.psi.cols();
  const Eigen::Index rows = r.psi.rows();
  Eigen::VectorXd col_norm = r.psi.colwise().norm().transpose();
  for (Eigen::Index c = 0; c < p; ++c) {
    if (!(col_norm(c) > 0.0)) {
      throw InputError(log_name + ": parameter '" +
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
    throw InputError(s.str());
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
  const double sigma2 = rows > p ? rss / static_cast<double>(rows - p) : 0.0;
  // Cov(beta) = sigma^2 D^-1 (S^T S)^-1 D^-1 with S = U Sigma V^T.
  const Eigen::MatrixXd vs = svd.matrixV() * sv.cwiseInverse().asDiagonal();
  const Eigen::VectorXd var_scaled = vs.rowwise().squaredNorm();
  out.std_dev = (sigma2 * var_scaled).cwiseSqrt().cwiseQuotient(col_norm);
  out.condition_number_scaled = sv(0) / sv(p - 1);
  Eigen::JacobiSVD<Eigen::MatrixXd> raw(r.psi.transpose() * r.psi);
  const Eigen::VectorXd ev = raw.singularValues();
  out.condition_number = std::sqrt(ev(0) / ev(p - 1));
  return out;
}

}  // namespace

LeastSquaresResult solve_least_squares(const Regression& r, const Model& model, LsSolver solver,
                                       LsWeights weights, const std::string& log_name) {
  LeastSquaresResult ols = solve_ordinary(r, model, solver, log_name);
  if (weights == LsWeights::kNone) return ols;
  const Eigen::VectorXd e = r.tau - r.psi * ols.beta;
  std::array<double, 3> var{};
  const std::size_t n = r.samples();
  for (std::size_t k = 0; k < n; ++k) {
    for (unsigned j = 0; j < 3; ++j) var[j] += std::pow(e(static_cast<Eigen::Index>(3 * k + j)), 2);
  }
  std::array<double, 3> w{};
  for (unsigned j = 0; j < 3; ++j) {
    var[j] /= static_cast<double>(n);
    w[j] = var[j] > 0.0 ? 1.0 / var[j] : 1.0;
  }
  // Normalise so the weights average to one over the joints.
  const double mean_w = (w[0] + w[1] + w[2]) / 3.0;
  for (double& x : w) x /= mean_w;
  LeastSquaresResult wls = solve_ordinary(weighted(r, w), model, solver, log_name);
  wls.joint_weights = w;
  return wls;
}

}  // namespace host_id
