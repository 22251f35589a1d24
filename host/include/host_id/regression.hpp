// The stacked linear regression tau = Psi beta of a model over samples, and
// the two ways to evaluate its cost, the mean squared torque error
//   cost(beta) = |tau - Psi beta|^2 / rows:
// directly (O(rows * p)) and from precomputed terms about a point (O(p^2)).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cstddef>
#include <vector>

#include "host_id/model.hpp"

namespace host_id {

// One equation (row) per joint and sample. As built, rows 3k..3k+2 belong to
// sample k, joints 1..3; without_slow_rows() leaves some out, so code that
// needs a row's joint reads joint[row].
struct Regression {
  Eigen::MatrixXd psi;               // N m per unit of each parameter
  Eigen::VectorXd tau;               // N m
  std::vector<double> t_s;           // time of sample k (of the full regression)
  std::vector<unsigned char> joint;  // the joint of each row, 0..2
  std::vector<double> speed_rad_s;   // |qd| of that joint at that row's sample
  std::vector<std::size_t> sample;   // the index into t_s of each row's sample
  std::size_t samples() const { return t_s.size(); }
  std::size_t rows() const { return static_cast<std::size_t>(tau.size()); }
  std::array<std::size_t, 3> rows_per_joint() const;
};

// The regression without the equations of joints slower than min_speed_rad_s
// at their sample. Near a reversal the Coulomb term switches within a few
// milliseconds, faster than the filtered velocity can place it, and the
// residual it leaves there biases the viscous estimate (docs/identification.md).
Regression without_slow_rows(const Regression& r, double min_speed_rad_s);

// Direct evaluation: one pass over all rows.
double direct_cost(const Regression& r, const Eigen::VectorXd& beta);

// The cost in O(p^2), expanded about a reference point beta0 (the
// least-squares solution), with d = beta - beta0 and r0 = tau - Psi beta0:
//   cost(beta) = (r0^T r0 - 2 d^T Psi^T r0 + d^T Psi^T Psi d) / rows.
// It equals the direct sum without the cancellation of the expansion about
// zero, (tau^T tau - 2 beta^T Psi^T tau + beta^T Psi^T Psi beta) / rows,
// whose large terms cancel to about 5e-9 relative near the optimum: here
// r0^T r0 is the cost at beta0 itself, and the other terms are small near
// it (Psi^T r0 is zero at the exact optimum, and is kept for the rest).
class QuadraticCost {
 public:
  QuadraticCost(const Regression& r, const Eigen::VectorXd& beta0);
  double operator()(const Eigen::VectorXd& beta) const;
  Eigen::Index parameters() const { return beta0_.size(); }

 private:
  Eigen::VectorXd beta0_;
  Eigen::MatrixXd psi_t_psi_;
  Eigen::VectorXd psi_t_r0_;
  double r0_t_r0_{0};
  double rows_{1};
};

// The mean of e^2 over each joint's rows (0 for a joint without rows).
std::array<double, 3> mean_square_per_joint(const Regression& r, const Eigen::VectorXd& e);

// Root mean square error per joint of the prediction Psi beta.
std::array<double, 3> rmse_per_joint(const Regression& r, const Eigen::VectorXd& beta);

}  // namespace host_id
