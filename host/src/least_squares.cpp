#include "host_id/least_squares.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <sstream>

#include "delta/input_error.hpp"

namespace host_id {

Regression weighted(const Equations& r, const std::array<double, 3>& w) {
  Regression out;
  out.psi = r.psi;
  out.tau = r.tau;
  out.t_s.assign(r.t_s.begin(), r.t_s.end());
  out.joint.assign(r.joint.begin(), r.joint.end());
  out.sample.assign(r.sample.begin(), r.sample.end());
  for (Eigen::Index row = 0; row < out.tau.size(); ++row) {
    const double s = std::sqrt(w[out.joint[static_cast<std::size_t>(row)]]);
    out.psi.row(row) *= s;
    out.tau(row) *= s;
  }
  return out;
}

namespace {

// h_k = sum over |l| <= L of (1 - |l|/(L+1)) g_(k+l), for k < n, with g
// zero from n to n + L - 1: the triangle as two boxes of L + 1 samples,
//   box_k = sum of g over [k - L, k],  h_k = sum of box over [k, k + L] / (L + 1),
// each a difference of running sums. sums holds n + L + 1 values, box n + L.
void bartlett_smooth(const double* g, Eigen::Index n, Eigen::Index l, double* sums, double* box,
                     double* h) {
  const Eigen::Index m = n + l;
  sums[0] = 0.0;
  for (Eigen::Index k = 0; k < m; ++k) sums[k + 1] = sums[k] + g[k];
  for (Eigen::Index k = 0; k < m; ++k)
    box[k] = sums[k + 1] - sums[std::max<Eigen::Index>(0, k - l)];
  for (Eigen::Index k = 0; k < m; ++k) sums[k + 1] = sums[k] + box[k];
  const double norm = 1.0 / static_cast<double>(l + 1);
  for (Eigen::Index k = 0; k < n; ++k) h[k] = (sums[std::min(m, k + l + 1)] - sums[k]) * norm;
}

// S of the covariance in the scaled coordinates (the columns of Psi divided
// by col_norm), per joint: each joint's g = a e laid out by sample (zero
// where the joint has no equation), then
//   S += G^T H,  H = G smoothed by the Bartlett weights 1 - |l|/(L+1),
// which is the sum over lags in one product. The triangle is two boxes of
// L+1 samples, each a difference of running sums: O(n p) for H. Lags run
// over the sample index, across a gap between segments too (a few pairs).
Eigen::MatrixXd lagged_score_covariance(const Equations& r, const Eigen::VectorXd& col_norm,
                                        const Eigen::VectorXd& e, std::size_t lags) {
  const Eigen::Index p = r.psi.cols();
  const auto n = static_cast<Eigen::Index>(r.samples());
  const auto l = std::min<Eigen::Index>(static_cast<Eigen::Index>(lags), n);
  const Eigen::RowVectorXd inverse_norm = col_norm.cwiseInverse().transpose();
  Eigen::MatrixXd s = Eigen::MatrixXd::Zero(p, p);
  // L zero rows after the last sample, so that the boxes reaching past it
  // are whole.
  const Eigen::Index m = n + l;
  Eigen::MatrixXd g(m, p);
  Eigen::VectorXd sums(m + 1), box(m), h(m);
  // Each joint's rows, listed once.
  std::array<std::vector<std::uint32_t>, 3> rows_of;
  for (std::size_t row = 0; row < r.rows(); ++row) {
    rows_of[r.joint[row]].push_back(static_cast<std::uint32_t>(row));
  }
  for (unsigned char j = 0; j < 3; ++j) {
    // Column by column: Psi is column-major, so each pass reads one column
    // in order.
    g.setZero();
    for (Eigen::Index c = 0; c < p; ++c) {
      const double* psi_c = r.psi.col(c).data();
      double* g_c = g.col(c).data();
      const double scale = inverse_norm(c);
      for (const std::uint32_t row : rows_of[j]) {
        g_c[r.sample[row]] = psi_c[row] * e(static_cast<Eigen::Index>(row)) * scale;
      }
    }
    if (l == 0) {
      s.noalias() += g.transpose() * g;
      continue;
    }
    // One smoothed column at a time: S's column c is G^T H_c.
    for (Eigen::Index c = 0; c < p; ++c) {
      bartlett_smooth(g.col(c).data(), n, l, sums.data(), box.data(), h.data());
      s.col(c).noalias() += g.topRows(n).transpose() * h.head(n);
    }
  }
  // Symmetric in exact arithmetic; make it so in floating point.
  return 0.5 * (s + s.transpose());
}

// The columns' norms, with 1 for a zero column (its scaled column stays
// zero), and the zero columns.
Eigen::VectorXd column_norms(const Equations& r, std::vector<std::size_t>& zero_columns) {
  Eigen::VectorXd col_norm = r.psi.colwise().norm().transpose();
  for (Eigen::Index c = 0; c < col_norm.size(); ++c) {
    if (!(col_norm(c) > 0.0)) {
      zero_columns.push_back(static_cast<std::size_t>(c));
      col_norm(c) = 1.0;
    }
  }
  return col_norm;
}

std::string names(const std::vector<std::size_t>& columns,
                  const std::vector<ParameterInfo>& parameters) {
  std::string s;
  for (const std::size_t c : columns) s += " '" + parameters[c].name + "'";
  return s;
}

// The independent columns of the scaled triangular factor rr (pivoted QR,
// a pivot below 1e-9 of the largest counts as zero) and the coefficients
// that give the dependent ones, in the parameters' own units.
Identifiability identifiability_of(const Eigen::MatrixXd& rr, const Eigen::VectorXd& col_norm,
                                   const std::vector<std::size_t>& zero_columns,
                                   const std::vector<ParameterInfo>& parameters,
                                   const std::string& log_name) {
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(rr);
  qr.setThreshold(1e-9);
  const Eigen::Index rank = qr.rank();
  const Eigen::Index p = rr.cols();
  const auto& perm = qr.colsPermutation().indices();
  // A_pivoted = Q [R11 R12; 0 ~0]: the dependent columns are A_I R11^-1 R12.
  const Eigen::MatrixXd r = qr.matrixR().topRows(rank).template triangularView<Eigen::Upper>();
  const Eigen::MatrixXd k =
      r.leftCols(rank).template triangularView<Eigen::Upper>().solve(r.rightCols(p - rank));
  Identifiability id;
  std::vector<std::pair<std::size_t, Eigen::Index>> independent, dependent;  // column, position
  for (Eigen::Index i = 0; i < p; ++i) {
    (i < rank ? independent : dependent).emplace_back(static_cast<std::size_t>(perm(i)), i);
  }
  std::sort(independent.begin(), independent.end());
  std::sort(dependent.begin(), dependent.end());
  id.coefficient.resize(rank, p - rank);
  for (std::size_t a = 0; a < independent.size(); ++a) {
    id.independent.push_back(independent[a].first);
    for (std::size_t b = 0; b < dependent.size(); ++b) {
      const auto row = static_cast<Eigen::Index>(a), col = static_cast<Eigen::Index>(b);
      // Scaled x = D beta: base_i = beta_i + K norm_d / norm_i beta_d.
      id.coefficient(row, col) = k(independent[a].second, dependent[b].second - rank) *
                                 col_norm(static_cast<Eigen::Index>(dependent[b].first)) /
                                 col_norm(static_cast<Eigen::Index>(independent[a].first));
    }
  }
  for (const auto& d : dependent) id.dependent.push_back(d.first);
  std::ostringstream s;
  s << log_name << ": the regressor is rank-deficient: this log";
  if (!zero_columns.empty()) {
    s << " does not excite" << names(zero_columns, parameters) << " at all";
  }
  std::vector<std::size_t> mixed;
  for (const std::size_t d : id.dependent) {
    if (std::find(zero_columns.begin(), zero_columns.end(), d) == zero_columns.end()) {
      mixed.push_back(d);
    }
  }
  if (!mixed.empty()) {
    s << (zero_columns.empty() ? "" : " and") << " cannot tell" << names(mixed, parameters)
      << " apart from the others";
  }
  id.message = s.str();
  return id;
}

// R of the column-scaled regressor A = Psi D^-1 = Q R, and the first p
// entries of Q^T tau, without a copy of A: blocks of rows are factored one
// after the other, each stacked under the R of those before (QR of the
// stack [R; A_block] gives the R of all the rows so far). tau rides along
// as a last column, so that the same reflections give Q^T tau.
struct TriangularFactor {
  Eigen::MatrixXd r;       // p x p, upper triangular
  Eigen::VectorXd qt_tau;  // p
};

TriangularFactor scaled_qr(const Equations& reg, const Eigen::VectorXd& col_norm) {
  const Eigen::Index p = reg.psi.cols();
  const Eigen::Index m = reg.psi.rows();
  constexpr Eigen::Index kBlockRows = 4096;
  const Eigen::RowVectorXd inverse_norm = col_norm.cwiseInverse().transpose();
  Eigen::MatrixXd stack(p + kBlockRows, p + 1);
  Eigen::MatrixXd top = Eigen::MatrixXd::Zero(p, p + 1);  // [R | Q^T tau] so far
  for (Eigen::Index start = 0; start < m; start += kBlockRows) {
    const Eigen::Index len = std::min(kBlockRows, m - start);
    const Eigen::Index above = start == 0 ? 0 : p;  // no R yet before the first block
    stack.topRows(above) = top;
    stack.block(above, 0, len, p) =
        reg.psi.middleRows(start, len).array().rowwise() * inverse_norm.array();
    stack.block(above, p, len, 1) = reg.tau.segment(start, len);
    Eigen::Ref<Eigen::MatrixXd> rows = stack.topRows(above + len);
    Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(rows);  // in place
    top = qr.matrixQR().topRows(p).triangularView<Eigen::Upper>();
  }
  return {top.leftCols(p), top.col(p)};
}

// The least-squares solution from R: everything after the QR is p x p. The
// singular values and right singular vectors of R are those of the scaled
// regressor (Q has orthonormal columns).
LeastSquaresResult solve_ordinary(const Equations& r, const std::vector<ParameterInfo>& parameters,
                                  LsSolver solver, const std::string& log_name, std::size_t lags) {
  const Eigen::Index p = r.psi.cols();
  const Eigen::Index rows = r.psi.rows();
  std::vector<std::size_t> zero_columns;
  const Eigen::VectorXd col_norm = column_norms(r, zero_columns);
  const auto [rr, qt_tau] = scaled_qr(r, col_norm);
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(rr, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::VectorXd sv = svd.singularValues();
  if (!zero_columns.empty() || sv(p - 1) <= 1e-10 * sv(0)) {
    Identifiability id = identifiability_of(rr, col_norm, zero_columns, parameters, log_name);
    const std::string message = id.message;
    throw RankDeficientError(message, std::move(id));
  }
  const Eigen::VectorXd beta_scaled =
      solver == LsSolver::kSvd ? Eigen::VectorXd(svd.solve(qt_tau))
                               : Eigen::VectorXd(rr.triangularView<Eigen::Upper>().solve(qt_tau));
  LeastSquaresResult out;
  out.unconstrained_beta = beta_scaled.cwiseQuotient(col_norm);
  const Eigen::VectorXd e = r.tau - r.psi * out.unconstrained_beta;
  out.unconstrained_cost = e.squaredNorm() / static_cast<double>(rows);
  // Scaling by the positive column norms keeps every bound at 0.
  std::vector<bool> nonnegative(static_cast<std::size_t>(p));
  bool inside = true;
  for (Eigen::Index c = 0; c < p; ++c) {
    nonnegative[static_cast<std::size_t>(c)] = parameters[static_cast<std::size_t>(c)].nonnegative;
    inside = inside && !(nonnegative[static_cast<std::size_t>(c)] && beta_scaled(c) < 0.0);
  }
  const Eigen::VectorXd x = inside ? beta_scaled : bounded_least_squares(rr, qt_tau, nonnegative);
  out.beta = x.cwiseQuotient(col_norm);
  for (Eigen::Index c = 0; c < p; ++c) {
    if (nonnegative[static_cast<std::size_t>(c)] && x(c) == 0.0) {
      out.active_bounds.push_back(static_cast<std::size_t>(c));
    }
  }
  out.cost = inside ? out.unconstrained_cost
                    : (r.tau - r.psi * out.beta).squaredNorm() / static_cast<double>(rows);
  // (A^T A)^-1 = V Sigma^-2 V^T for the scaled regressor A = U Sigma V^T.
  const Eigen::MatrixXd vs = svd.matrixV() * sv.cwiseInverse().asDiagonal();
  const Eigen::MatrixXd inv_ata = vs * vs.transpose();
  const double dof = rows > p ? static_cast<double>(rows) / static_cast<double>(rows - p) : 0.0;
  const Eigen::MatrixXd cov_scaled =
      dof * inv_ata * lagged_score_covariance(r, col_norm, e, lags) * inv_ata;
  out.std_dev = cov_scaled.diagonal().cwiseMax(0.0).cwiseSqrt().cwiseQuotient(col_norm);
  out.correlation_lags = lags;
  out.condition_number_scaled = sv(0) / sv(p - 1);
  // Psi = Q R D: its singular values are those of R D.
  const Eigen::VectorXd raw_sv = (rr * col_norm.asDiagonal()).jacobiSvd().singularValues();
  out.condition_number = raw_sv(0) / raw_sv(p - 1);
  return out;
}

// The least-squares solution over the passive columns, the others at 0.
Eigen::VectorXd solve_over(const Eigen::MatrixXd& r, const Eigen::VectorXd& b,
                           const std::vector<bool>& passive) {
  std::vector<Eigen::Index> columns;
  for (Eigen::Index c = 0; c < r.cols(); ++c) {
    if (passive[static_cast<std::size_t>(c)]) columns.push_back(c);
  }
  Eigen::VectorXd z = Eigen::VectorXd::Zero(r.cols());
  if (columns.empty()) return z;
  Eigen::MatrixXd a(r.rows(), static_cast<Eigen::Index>(columns.size()));
  for (std::size_t k = 0; k < columns.size(); ++k) {
    a.col(static_cast<Eigen::Index>(k)) = r.col(columns[k]);
  }
  const Eigen::VectorXd zp = a.householderQr().solve(b);
  for (std::size_t k = 0; k < columns.size(); ++k) {
    z(columns[k]) = zp(static_cast<Eigen::Index>(k));
  }
  return z;
}

}  // namespace

Eigen::VectorXd bounded_least_squares(const Eigen::MatrixXd& r, const Eigen::VectorXd& b,
                                      const std::vector<bool>& nonnegative) {
  const auto p = static_cast<std::size_t>(r.cols());
  std::vector<bool> passive(p);
  for (std::size_t c = 0; c < p; ++c) passive[c] = !nonnegative[c];
  // Feasible start: the free parameters' optimum with the bounded ones at 0.
  Eigen::VectorXd x = solve_over(r, b, passive);
  const double tolerance = 1e-12 * r.norm() * b.norm();
  for (std::size_t outer = 0; outer < 3 * p + 3; ++outer) {
    // The descent direction of each bounded parameter held at 0.
    const Eigen::VectorXd w = r.transpose() * (b - r * x);
    std::size_t enter = p;
    double largest = tolerance;
    for (std::size_t c = 0; c < p; ++c) {
      const auto i = static_cast<Eigen::Index>(c);
      if (!passive[c] && w(i) > largest) {
        enter = c;
        largest = w(i);
      }
    }
    if (enter == p) break;  // the KKT conditions hold
    passive[enter] = true;
    for (std::size_t inner = 0; inner <= p; ++inner) {
      const Eigen::VectorXd z = solve_over(r, b, passive);
      double step = 1.0;
      std::size_t limiting = p;
      for (std::size_t c = 0; c < p; ++c) {
        const auto i = static_cast<Eigen::Index>(c);
        if (passive[c] && nonnegative[c] && z(i) <= 0.0) {
          const double gap = x(i) - z(i);
          const double s = gap > 0.0 ? x(i) / gap : 0.0;
          if (s < step || limiting == p) {
            step = std::min(step, s);
            limiting = c;
          }
        }
      }
      if (limiting == p) {
        x = z;
        break;
      }
      // Step to the first bound met and hold the parameters there.
      x += step * (z - x);
      x(static_cast<Eigen::Index>(limiting)) = 0.0;
      for (std::size_t c = 0; c < p; ++c) {
        const auto i = static_cast<Eigen::Index>(c);
        if (passive[c] && nonnegative[c] && x(i) <= 0.0) {
          passive[c] = false;
          x(i) = 0.0;
        }
      }
    }
  }
  return x;
}

std::size_t correlation_lags_for(double sample_rate_hz, double cutoff_hz) {
  if (!(sample_rate_hz > 0.0) || !(cutoff_hz > 0.0)) return 0;
  return static_cast<std::size_t>(std::ceil(2.0 * sample_rate_hz / cutoff_hz));
}

LeastSquaresResult solve_least_squares(const Equations& r, const Model& model, LsSolver solver,
                                       LsWeights weights, const std::string& log_name,
                                       std::size_t correlation_lags) {
  return solve_least_squares(r, model.parameters(), solver, weights, log_name, correlation_lags);
}

double bounded_least_squares_cost(const Equations& r, const std::vector<ParameterInfo>& parameters,
                                  const std::string& log_name) {
  const Eigen::Index p = r.psi.cols();
  std::vector<std::size_t> zero_columns;
  const Eigen::VectorXd col_norm = column_norms(r, zero_columns);
  if (!zero_columns.empty()) {
    throw delta::InputError(log_name + ": this log does not excite" +
                            names(zero_columns, parameters) + " at all");
  }
  const auto [rr, qt_tau] = scaled_qr(r, col_norm);
  std::vector<bool> nonnegative(static_cast<std::size_t>(p));
  for (std::size_t c = 0; c < nonnegative.size(); ++c) nonnegative[c] = parameters[c].nonnegative;
  const Eigen::VectorXd x = bounded_least_squares(rr, qt_tau, nonnegative);
  // |tau - Psi beta|^2 = |tau|^2 - |Q^T tau|^2 + |R x - Q^T tau|^2.
  const double sum = r.tau.squaredNorm() - qt_tau.squaredNorm() + (rr * x - qt_tau).squaredNorm();
  return std::max(0.0, sum) / static_cast<double>(r.rows());
}

LeastSquaresResult solve_least_squares(const Equations& r,
                                       const std::vector<ParameterInfo>& parameters,
                                       LsSolver solver, LsWeights weights,
                                       const std::string& log_name, std::size_t correlation_lags) {
  LeastSquaresResult ols = solve_ordinary(r, parameters, solver, log_name, correlation_lags);
  if (weights == LsWeights::kNone) return ols;
  const std::array<double, 3> var = mean_square_per_joint(r, r.tau - r.psi * ols.beta);
  std::array<double, 3> w{};
  for (unsigned j = 0; j < 3; ++j) w[j] = var[j] > 0.0 ? 1.0 / var[j] : 1.0;
  // Normalise so the weights average to one over the joints.
  const double mean_w = (w[0] + w[1] + w[2]) / 3.0;
  for (double& x : w) x /= mean_w;
  LeastSquaresResult wls =
      solve_ordinary(weighted(r, w), parameters, solver, log_name, correlation_lags);
  wls.joint_weights = w;
  return wls;
}

}  // namespace host_id
