// Least squares: the exact optimum of the mean squared torque error, with the
// parameters' covariance.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <vector>

#include "delta/input_error.hpp"
#include "host_id/model.hpp"
#include "host_id/regression.hpp"

namespace host_id {

enum class LsSolver { kQr, kSvd };

// Which parameters a log can tell apart. Where columns of the regressor
// are (numerically) combinations of others, only combinations of the
// parameters are identifiable: the base parameters
//   base_i = beta_i + sum_k coefficient(i, k) beta_dependent[k]
// for i over the independent columns (a column-pivoting QR of the scaled
// regressor's triangular factor picks them). A column that is zero has no
// coefficient: its parameter is not excited at all.
struct Identifiability {
  std::vector<std::size_t> independent;  // ascending
  std::vector<std::size_t> dependent;    // ascending
  Eigen::MatrixXd coefficient;           // independent.size() x dependent.size()
  std::string message;                   // what the log cannot separate, by name
};

// Thrown by solve_least_squares where the regressor is rank-deficient; its
// message names the parameters, and identifiability() says how to go on.
class RankDeficientError : public delta::InputError {
 public:
  RankDeficientError(const std::string& message, Identifiability i)
      : delta::InputError(message), identifiability_(std::move(i)) {}
  const Identifiability& identifiability() const { return identifiability_; }

 private:
  Identifiability identifiability_;
};
enum class LsWeights { kNone, kJoint };

struct LeastSquaresResult {
  // The optimum within the physical bounds (the model's nonnegative
  // parameters >= 0): the unconstrained optimum where that lies inside them.
  Eigen::VectorXd beta;
  Eigen::VectorXd unconstrained_beta;
  std::vector<std::size_t> active_bounds;  // parameters held at 0 by their bound
  Eigen::VectorXd std_dev;                 // sqrt of the covariance's diagonal
  // With model error (motion_spread.hpp): set by the fit, empty here.
  Eigen::VectorXd honest_std_dev;
  Eigen::MatrixXd correlation;        // the covariance as correlations (unit diagonal)
  std::size_t correlation_lags{0};    // of the covariance estimate (0: white residuals)
  double cost{0};                     // mean squared error of the (weighted) rows at beta
  double unconstrained_cost{0};       // ... at unconstrained_beta
  double condition_number{0};         // of Psi, raw units
  double condition_number_scaled{0};  // of Psi with unit-norm columns
  std::array<double, 3> joint_weights{1, 1, 1};
  // The moments of the (weighted) rows solved, for a cost in O(p^2)
  // (QuadraticCost) without another pass over them.
  Eigen::MatrixXd psi_t_psi;  // full
  Eigen::VectorXd psi_t_tau;
  double tau_t_tau{0};
};

// The Gram matrices [Psi tau]^T [Psi tau] of each joint's rows of a
// regression ((p+1) x (p+1), full), where a pass over the rows has already
// summed them (judge_support's): the least squares then adds them up,
// weighted, instead of making its own pass.
struct JointGrams {
  std::array<Eigen::MatrixXd, 3> of_joint;
  // The Gram matrix of the rows weighted by joint: joint j's times w[j]
  // (p: the regression's columns, which the matrices must have and tau).
  Eigen::MatrixXd weighted(const std::array<double, 3>& w, Eigen::Index p) const {
    for (const Eigen::MatrixXd& g : of_joint) {
      if (g.rows() != p + 1 || g.cols() != p + 1) {
        throw std::logic_error("JointGrams: Gram matrices of another regression");
      }
    }
    return w[0] * of_joint[0] + w[1] * of_joint[1] + w[2] * of_joint[2];
  }
};

// Solves min |tau - Psi beta|^2 subject to beta_c >= 0 for each parameter
// the model marks nonnegative (exactly: an active-set method on the
// regressor's triangular factor). With kJoint, two steps: ordinary least
// squares, then weights 1 / sigma_j^2 from each joint's residual variance.
// Throws RankDeficientError when Psi is rank-deficient, naming the
// parameters that the data cannot tell apart.
//
// The covariance allows for residuals correlated over up to
// correlation_lags samples of the same joint (Newey-West, Bartlett weights):
//   Cov = (Psi^T Psi)^-1 S (Psi^T Psi)^-1,
//   S = sum over |l| <= L of (1 - |l|/(L+1)) sum_k g_k g_(k-l)^T,
//   g_k = psi_k e_k.
// Filtered residuals are correlated over about fs / f_cutoff samples, and
// the white-noise formula (L = 0) then understates the spread several times.
// The passes over the rows run on `threads` threads (0: one per core) for
// long regressions, with the same result on any number of them. With
// `grams` (of r's rows), the Gram matrix is their sum: equal to the pass's
// to rounding.
LeastSquaresResult solve_least_squares(const Equations& r, const Model& model, LsSolver solver,
                                       LsWeights weights, const std::string& log_name,
                                       std::size_t correlation_lags = 0, unsigned threads = 1);
// The same for columns described by `parameters` (names and bounds).
LeastSquaresResult solve_least_squares(const Equations& r,
                                       const std::vector<ParameterInfo>& parameters,
                                       LsSolver solver, LsWeights weights,
                                       const std::string& log_name,
                                       std::size_t correlation_lags = 0, unsigned threads = 1,
                                       const JointGrams* grams = nullptr);

// The cost (mean squared error) of the bounded optimum alone: no
// covariance, for a search that solves many problems (variable projection).
double bounded_least_squares_cost(const Equations& r, const std::vector<ParameterInfo>& parameters,
                                  const std::string& log_name);

// min |R x - b|^2 subject to x_c >= 0 where nonnegative[c], for a square
// upper-triangular R of full rank: the Lawson-Hanson active-set method, with
// the parameters without a bound always free. Exact in at most a few
// passes over p; returns x.
Eigen::VectorXd bounded_least_squares(const Eigen::MatrixXd& r, const Eigen::VectorXd& b,
                                      const std::vector<bool>& nonnegative);

// The lags for a log sampled at sample_rate_hz whose residuals were low-pass
// filtered at cutoff_hz: two correlation lengths, 2 fs / f_cutoff.
std::size_t correlation_lags_for(double sample_rate_hz, double cutoff_hz);

}  // namespace host_id
