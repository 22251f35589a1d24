// The stacked linear regression tau = Psi beta of a model over samples, and
// the two ways to evaluate its cost, the mean squared torque error
//   cost(beta) = |tau - Psi beta|^2 / rows:
// directly (O(rows * p)) and from precomputed terms about a point (O(p^2)).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cstddef>
#include <span>
#include <vector>

#include "host_id/model.hpp"

namespace host_id {

// The moments of each joint's unfiltered equations over the kept samples:
// the regressor rows before parallel filtering and the measured torque, so
// that the RMSE against the measured torque (what a user compares, noise
// included) follows for any beta without a second pass over the log:
//   sum (tau - row beta)^2 = tau_sq - 2 beta^T psi_t_tau + beta^T psi_t_psi beta.
// The large terms cancel: the RMSE has a floor near 1e-7 of the RMS torque
// (measured 5e-8 N m on an exact fit), enough for a report, not for an
// optimiser (QuadraticCost).
struct MeasuredMoments {
  std::array<Eigen::MatrixXd, 3> psi_t_psi;  // upper triangle
  std::array<Eigen::VectorXd, 3> psi_t_tau;
  std::array<double, 3> tau_sq{};
  std::array<std::size_t, 3> rows{};
  void reset(std::size_t parameters);
  // The rows of one joint, a block at a time: rows are the columns of a
  // p x n matrix (taken into the sums by one rank update), with their torques.
  void add(unsigned joint,
           const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>>& rows_as_columns,
           const Eigen::Map<const Eigen::VectorXd, 0, Eigen::InnerStride<3>>& tau);
  void merge(const MeasuredMoments& other);
  // The RMSE per joint against the measured torque (0 for a joint without rows).
  std::array<double, 3> rmse(const Eigen::VectorXd& beta) const;
};

// One equation (row) per joint and sample. As built, rows 3k..3k+2 belong to
// sample k, joints 1..3; a fit has the rows of slow joints put last
// (PrepareOptions::slow_rows_last_below_rad_s), so code that needs a
// row's joint or sample reads joint[row] and sample[row].
struct Regression {
  Eigen::MatrixXd psi;                 // N m per unit of each parameter
  Eigen::VectorXd tau;                 // N m
  std::vector<double> t_s;             // time of sample k
  std::vector<unsigned char> joint;    // the joint of each row, 0..2
  std::vector<double> velocity_rad_s;  // qd of that joint at that row's sample
  std::vector<std::size_t> sample;     // the index into t_s of each row's sample
  MeasuredMoments measured;            // the kept samples' rows before filtering
  // The columns that are not zero in some row of joint j, ascending; every
  // other column is zero in all of joint j's rows (another joint's
  // friction, say). They describe psi while it has joint_columns_of
  // columns: code that adds columns leaves them behind, and they are then
  // not used (every column is taken), as where they are empty.
  std::array<std::vector<Eigen::Index>, 3> joint_columns;
  Eigen::Index joint_columns_of{0};
  std::size_t samples() const { return t_s.size(); }
  std::size_t rows() const { return static_cast<std::size_t>(tau.size()); }
  std::array<std::size_t, 3> rows_per_joint() const;
};

// The first rows of a regression, without a copy: the equations an
// estimate uses (all of them, or the fast ones before the slow ones).
struct Equations {
  Equations(const Regression& r);  // every row (implicit: a regression is its equations)
  Equations(const Regression& r, std::size_t first_rows);
  Eigen::Ref<const Eigen::MatrixXd> psi;
  Eigen::Ref<const Eigen::VectorXd> tau;
  std::span<const unsigned char> joint;
  std::span<const std::size_t> sample;
  std::span<const double> t_s;                                 // every sample of the regression
  std::array<std::span<const Eigen::Index>, 3> joint_columns;  // as Regression's,
  Eigen::Index joint_columns_of;                               // for this many columns
  std::size_t samples() const { return t_s.size(); }
  std::size_t rows() const { return static_cast<std::size_t>(tau.size()); }
  std::array<std::size_t, 3> rows_per_joint() const;
};

// The squared residuals e = tau - Psi beta summed per joint, over the first
// `first_rows` rows (the equations an estimate used: those before the
// slow ones) and over every row: the cost of an estimate and its
// RMSE, from one pass over the rows with no residual vector. The rows go in
// chunks of fixed length to `threads` threads (0: one per core), the
// chunks' sums added in order: the same sums on any number of threads.
struct ResidualSquares {
  std::array<double, 3> first{};  // rows [0, first_rows)
  std::array<double, 3> all{};    // every row
  // The mean over the first rows with joint j's squares weighted by
  // joint_weights[j]: the cost of an estimate weighted as it was.
  double cost(const std::array<double, 3>& joint_weights, std::size_t first_rows) const;
};
ResidualSquares residual_squares(const Equations& r, std::size_t first_rows,
                                 const Eigen::VectorXd& beta, unsigned threads = 1);

// Direct evaluation: one pass over all rows.
double direct_cost(const Equations& r, const Eigen::VectorXd& beta);
// The same with joint j's rows weighted by joint_weights[j]: the cost of the
// weighted problem (each joint's rows scaled by sqrt(joint_weights[j]))
// without a weighted copy of the rows.
double direct_cost(const Equations& r, const Eigen::VectorXd& beta,
                   const std::array<double, 3>& joint_weights);

// The cost in O(p^2), expanded about a reference point beta0 (the
// least-squares solution), with d = beta - beta0 and r0 = tau - Psi beta0:
//   cost(beta) = (r0^T r0 - 2 d^T Psi^T r0 + d^T Psi^T Psi d) / rows.
// It equals the direct sum without the cancellation of the expansion about
// zero, (tau^T tau - 2 beta^T Psi^T tau + beta^T Psi^T Psi beta) / rows,
// whose large terms cancel to about 5e-9 relative near the optimum: here
// r0^T r0 is the cost at beta0 itself, and the other terms are small near
// it (Psi^T r0 is zero at the exact optimum, and is kept for the rest).
// The terms come from the rows (two passes over them), or from moments the
// least-squares solve has already formed (Psi^T Psi, Psi^T tau, and the
// cost at beta0 computed directly): then Psi^T r0 = Psi^T tau - Psi^T Psi
// beta0, which is small near the optimum and enters only multiplied by d.
// The symmetric Psi^T Psi enters through its upper triangle: half the
// products of the full matrix. An evaluation allocates nothing (PSO makes
// hundreds of thousands of them), so one object serves several threads.
class QuadraticCost {
 public:
  QuadraticCost(const Equations& r, const Eigen::VectorXd& beta0);
  // psi_t_psi full (both triangles); r0_t_r0 = |tau - Psi beta0|^2.
  QuadraticCost(const Eigen::MatrixXd& psi_t_psi, const Eigen::VectorXd& psi_t_tau,
                const Eigen::VectorXd& beta0, double r0_t_r0, std::size_t rows);
  double operator()(const Eigen::VectorXd& beta) const { return at(beta.data()); }
  // The cost at the p values from `beta` on.
  double at(const double* beta) const;
  Eigen::Index parameters() const { return static_cast<Eigen::Index>(beta0_.size()); }
  // The same cost over a box's normalised coordinates u, beta = lower + u
  // (upper - lower) (every lower < upper): what PSO searches, so that it
  // evaluates u without mapping it to beta first.
  QuadraticCost over_box(const Eigen::VectorXd& lower, const Eigen::VectorXd& upper) const;

 private:
  void set(const Eigen::MatrixXd& psi_t_psi, const Eigen::VectorXd& psi_t_r0,
           const Eigen::VectorXd& beta0);
  std::vector<double> beta0_;
  std::vector<double> half_;  // Psi^T Psi's upper triangle with half its diagonal, column-major
  std::vector<double> psi_t_r0_;
  double r0_t_r0_{0};
  double per_row_{1};  // 1 / rows
};

// Root mean square error per joint of the prediction Psi beta.
std::array<double, 3> rmse_per_joint(const Equations& r, const Eigen::VectorXd& beta);
// The same from residual_squares(): sqrt(all[j] / rows of joint j), 0 for a
// joint without rows.
std::array<double, 3> rmse_per_joint(const Equations& r, const ResidualSquares& squares);

}  // namespace host_id
