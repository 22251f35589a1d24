// One preprocessing step, from a log to the regression that estimation
// consumes: it designs the low-pass filter, splits the log at its gaps,
// filters q and differentiates it (where the log has no qd/qdd columns),
// builds the regressor Psi, filters its columns and tau alike ("parallel
// filtering"), and trims the filters' end transients. docs/preprocessing.md
// describes each step.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "host_id/delta_log.hpp"
#include "host_id/model.hpp"
#include "host_id/motion_ranges.hpp"
#include "host_id/regression.hpp"

namespace host_id {

// The parallel filter's cut-off: 20 Hz keeps the excitation (harmonics up
// to ~2 Hz) untouched (4th-order Butterworth run twice: gain 1 - 1e-10 at
// 2 Hz) and removes the torque noise above it.
constexpr double kDefaultCutoffHz = 20.0;

struct PrepareOptions {
  // Of the parallel filter: tau and the regressor's columns alike.
  double cutoff_hz{kDefaultCutoffHz};
  // Of q's filter before its differences; none: chosen from each log's own
  // content (choose_state_cutoff, signal.hpp), --cutoff-hz where the log
  // is too short or too still to judge by.
  std::optional<double> state_cutoff_hz;
  // The samples' times where q is differentiated (delta_log.hpp): checked
  // (uneven steps refused), the nominal median step, or as logged.
  TimeSteps time_steps{TimeSteps::kCheck};
  // Samples dropped at each end of every segment after filtering; negative:
  // automatic, three periods of the cut-off frequency (150 samples at 1 kHz
  // and 20 Hz). Measured on a noise-free 8 s log: one period leaves errors
  // of 1e-3 in the friction parameters from the filters' end transients
  // (q, then the regressor columns), three periods 4e-5.
  long trim_samples{-1};
  // Rows of a joint slower than this at their sample (|qd|, rad/s) go after
  // every other row, each group in time order; 0: every row in time order.
  // A fit's equations are the fast ones (FitOptions::min_speed_rad_s):
  // built in this order, the regression needs no reordering after.
  double slow_rows_last_below_rad_s{0};
};

// What preprocessing did, for the report.
struct PreprocessReport {
  std::size_t samples_in_log{0};
  std::size_t segments_used{0};
  std::size_t segments_dropped{0};  // too short to fit after trimming
  std::string derivatives;          // how qd and qdd were obtained
  double sample_rate_hz{0};
  double state_cutoff_hz{0};  // q's filter's; 0: the log's qd, qdd columns
  MotionRanges ranges;        // of the kept samples' states
};

struct Preprocessed {
  Regression regression;     // every kept sample, three rows each
  std::size_t fast_rows{0};  // the rows before the slow ones (all of them without a threshold)
  PreprocessReport report;
};

// The joint states of the samples a fit keeps (every segment long enough,
// its ends trimmed), before the regressor: q filtered and differentiated,
// or the log's qd and qdd as they are. Throws as preprocess() does.
struct PreparedStates {
  std::vector<std::size_t> log_index;  // of each kept sample in the log
  std::vector<delta::JointState> states;
  PreprocessReport report;
};
PreparedStates prepare_states(const DeltaLog& log, const PrepareOptions& options);

// Throws delta::InputError naming the log: options that do not suit it,
// nothing left to fit, or a pose without forward kinematics (with its time).
// The regressor is built on `threads` threads (0: all cores).
Preprocessed preprocess(const Model& model, const DeltaLog& log, const PrepareOptions& options,
                        unsigned threads = 0);
// The same, freeing the log's samples (release_samples) as soon as the
// joint states are taken from them, so that the log's columns and the
// regressor are never in memory together (a fit's peak); the log keeps its
// name, geometry and gaps.
Preprocessed preprocess_releasing(const Model& model, DeltaLog& log, const PrepareOptions& options,
                                  unsigned threads = 0);

// A log preprocessed once for fits that differ only in the friction's shape
// (Model::shape_terms: the Coulomb smoothing, the Stribeck velocity), as
// --fit-friction-shape makes: the joint states and the row layout are kept,
// and another shape recomputes and filters only its own columns, the same
// values as preprocess() with that shape gives. Throws as preprocess().
class ShapePreprocess {
 public:
  ShapePreprocess(const Model& model, const DeltaLog& log, const PrepareOptions& options,
                  unsigned threads = 0);
  ~ShapePreprocess();
  ShapePreprocess(const ShapePreprocess&) = delete;
  ShapePreprocess& operator=(const ShapePreprocess&) = delete;
  // The preprocessed log under `model`: the model given at construction
  // with another friction shape. Valid until the next call; its regression
  // has no measured-torque moments (regression.measured is empty).
  const Preprocessed& with_shape(const Model& model);

 private:
  struct Kept;
  std::unique_ptr<Kept> kept_;
};

}  // namespace host_id
