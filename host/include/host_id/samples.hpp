// From a log to the samples a model is fitted on: joint states (q, qd, qdd)
// and torques, with derivatives estimated where the log has none. Gaps split
// the log into segments that are processed separately and never bridged.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "delta/dynamics.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/signal.hpp"

namespace host_id {

// 20 Hz keeps the excitation (harmonics up to ~2 Hz) untouched (4th-order
// Butterworth run twice: gain 1 - 1e-10 at 2 Hz) and cuts the white
// quantisation noise of a 17-bit encoder at 1 kHz by a factor of 5 in q and
// ~100 in qdd compared with unfiltered five-point differences.
constexpr double kDefaultCutoffHz = 20.0;

struct PrepareOptions {
  double cutoff_hz{kDefaultCutoffHz};
  // Samples dropped at each end of every segment after filtering; negative:
  // automatic, three periods of the cut-off frequency (150 samples at 1 kHz
  // and 20 Hz). Measured on a noise-free 8 s log: one period leaves errors
  // of 1e-3 in the friction parameters from the filters' end transients
  // (q, then the regressor columns), three periods 4e-5.
  long trim_samples{-1};
};

// A contiguous run of samples [begin, end) between gaps.
struct Segment {
  std::size_t begin{0}, end{0};
};

// States from the (filtered) angles and the raw torques, for every sample of
// every segment long enough to use. The regression (regression.hpp) filters
// its columns and the torques alike and then drops `trim` samples at each
// segment end.
struct Samples {
  std::vector<delta::JointState> states;
  std::vector<delta::Joint3> tau_Nm;
  std::vector<double> t_s;
  std::vector<Segment> segments;
  bool parallel_filter{false};  // filter regressor columns and torques
  std::array<Biquad, 2> filter{};
  std::size_t pad{0};
  std::size_t trim{0};
  std::size_t segments_used{0};
  std::size_t segments_dropped{0};  // too short to fit after trimming
  std::size_t samples_in_log{0};
  std::string derivatives;  // how qd and qdd were obtained, for the report
  double sample_rate_hz{0};
  std::size_t size() const { return states.size(); }
};

// Throws delta::InputError (naming the log) if the options do not suit the log, or
// if nothing is left to fit.
Samples prepare_samples(const DeltaLog& log, const PrepareOptions& options);

}  // namespace host_id
