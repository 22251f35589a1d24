#include "host_id/stribeck_signature.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>

#include "delta/dynamics.hpp"

namespace host_id {

namespace {

// The Stribeck velocities tried, rad/s.
constexpr std::array<double, 5> kTried{0.02, 0.05, 0.1, 0.2, 0.5};

// How much three Stribeck columns (one per joint) explain of the residual
// e of the least-squares fit of x: the SSE they remove and their
// coefficients (Frisch-Waugh: the columns' part orthogonal to x's).
struct Explained {
  double sse_removed{0};
  Eigen::Vector3d coefficient = Eigen::Vector3d::Zero();
};

Explained explained(const Eigen::MatrixXd& x, const Eigen::LDLT<Eigen::MatrixXd>& gram,
                    const Eigen::VectorXd& e, const Eigen::MatrixXd& s) {
  const Eigen::MatrixXd xs = x.transpose() * s;
  const Eigen::Matrix3d m = s.transpose() * s - xs.transpose() * gram.solve(xs);
  const Eigen::Vector3d se = s.transpose() * e;
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(m);
  Explained out;
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-12)) return out;
  out.coefficient = ldlt.solve(se);
  out.sse_removed = se.dot(out.coefficient);
  return out;
}

}  // namespace

std::optional<StribeckSignature> stribeck_signature(const Regression& r, std::size_t first_rows,
                                                    double coulomb_smoothing_rad_s,
                                                    std::size_t step) {
  step = std::max<std::size_t>(step, 1);
  const std::size_t n = (first_rows + step - 1) / step;
  const Eigen::Index p = r.psi.cols();
  if (n < static_cast<std::size_t>(10 * (p + 3))) return std::nullopt;
  Eigen::MatrixXd x(static_cast<Eigen::Index>(n), p);
  Eigen::VectorXd y(static_cast<Eigen::Index>(n));
  for (std::size_t k = 0; k < n; ++k) {
    x.row(static_cast<Eigen::Index>(k)) = r.psi.row(static_cast<Eigen::Index>(k * step));
    y(static_cast<Eigen::Index>(k)) = r.tau(static_cast<Eigen::Index>(k * step));
  }
  const Eigen::LDLT<Eigen::MatrixXd> gram(x.transpose() * x);
  if (gram.info() != Eigen::Success) return std::nullopt;
  const Eigen::VectorXd e = y - x * gram.solve(x.transpose() * y);
  const double sse = e.squaredNorm();
  std::optional<StribeckSignature> best;
  for (const double vs : kTried) {
    Eigen::MatrixXd s = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n), 3);
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t row = k * step;
      s(static_cast<Eigen::Index>(k), r.joint[row]) =
          delta::friction_shape_terms(r.velocity_rad_s[row], coulomb_smoothing_rad_s, vs).stribeck;
    }
    const Explained ex = explained(x, gram, e, s);
    // On every joint, each at least a fifth of the largest: a drive
    // train's effect, not one joint's residue.
    if (!(ex.coefficient.minCoeff() > kStribeckJointShare * ex.coefficient.maxCoeff()) ||
        !(sse > 0.0)) {
      continue;
    }
    const double drop = 1.0 - std::sqrt(std::max(0.0, 1.0 - ex.sse_removed / sse));
    if (drop > kStribeckDrop && (!best || drop > best->error_drop)) {
      best = StribeckSignature{vs, drop};
    }
  }
  return best;
}

}  // namespace host_id
