// A standard deviation that includes model error (docs/trust.md).
//
// Least squares' covariance measures what noise does to an estimate, and
// nothing in it grows with the bias an effect the model lacks leaves
// behind (a Stribeck dip, cogging, a twisting gearbox): the bias stays
// while that covariance shrinks with every sample. Such a bias depends on
// the motion the log holds: the rows where one column is large pull the
// estimate one way, those where it is small another. The estimate's spread
// over the log's own motions measures it:
//   - for each column k, the rows where it is not zero go into
//     kSpreadBins bins of equal count by its value (and, for drift or
//     runs glued together, all rows into kSpreadBins spans of time);
//   - each bin is left out in turn and the rest fitted (unconstrained
//     least squares, the joints' weights as the fit's);
//   - the delete-a-bin jackknife over those fits gives each parameter a
//     variance per partition, and its spread is the largest of them.
// With a model that holds, every partition's fits agree within the noise,
// and the spread is about least squares' own standard deviation; the
// honest standard deviation is the larger of the two.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cstddef>

#include "host_id/least_squares.hpp"
#include "host_id/regression.hpp"

namespace host_id {

inline constexpr unsigned kSpreadBins = 3;

struct MotionSpread {
  Eigen::VectorXd std_dev;         // over every partition, the largest; NaN where none could tell
  Eigen::VectorXd time_std_dev;    // over the spans of time alone
  Eigen::VectorXd column_std_dev;  // over the columns' partitions alone
};

// Every `step`-th row is used (rows filtered far below the sample rate
// carry little more). A partition whose bins cannot each be left out with
// every parameter still determined is skipped. The partitions are shared
// out over `threads` threads (0: one per core); the result is the same on
// any number.
MotionSpread motion_spread(const Equations& r, const std::array<double, 3>& joint_weights,
                           std::size_t step, unsigned threads);

// The step that takes the rows at the Nyquist rate of the filtered
// signals, fs / (2 f_cutoff), from the correlation lags (2 fs / f_cutoff).
inline std::size_t nyquist_step(std::size_t correlation_lags) {
  return correlation_lags / 4 > 0 ? correlation_lags / 4 : 1;
}

// ls.honest_std_dev: the larger of ls.std_dev and the motion spread, its
// rows every nyquist_step(correlation_lags)-th.
MotionSpread add_model_error(const Equations& r, std::size_t correlation_lags,
                             LeastSquaresResult& ls, unsigned threads);

}  // namespace host_id
