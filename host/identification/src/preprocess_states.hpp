// preprocess()'s first step, internal to host_id_identification: the
// low-pass filters designed for one log, and the joint states (q filtered
// and differentiated, or the log's qd and qdd) of every segment between
// its gaps.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "delta/dynamics.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/signal.hpp"

namespace host_id::preprocessing {

// A contiguous run of samples [begin, end) between gaps, and where it
// starts in the log.
struct Segment {
  std::size_t begin{0}, end{0};
  std::size_t log_begin{0};
};

// The filter and how much it needs at the ends, designed for one log.
struct FilterDesign {
  bool logged_derivatives{false};  // the log has qd and qdd: no filtering at all
  std::array<Biquad, 2> filter{};  // tau and the regressor's columns
  std::size_t pad{0};              // reflected samples at each end of a filtered series
  StateCutoff state;               // q's filter before its differences
  std::array<Biquad, 2> state_filter{};
  std::size_t state_pad{0};
  std::size_t trim{0};  // samples dropped at each segment end after filtering
  double sample_rate_hz{0};
  double median_step_s{0};    // of the whole log
  bool nominal_steps{false};  // differentiate at the median step, whatever the times
};

// Joint states and torques of every sample of every segment long enough to
// use, with q filtered and differentiated unless the log carries qd, qdd.
struct States {
  std::vector<delta::JointState> states;
  std::vector<delta::Joint3> tau_Nm;
  std::vector<double> t_s;
  std::vector<Segment> segments;
  bool any_nonuniform{false};
  std::size_t segments_dropped{0};
  std::size_t size() const { return states.size(); }
};

// Samples per thread that pay for its start-up.
constexpr std::size_t kSamplesPerThread = 20000;

// The filters of one log, checked against it; throws delta::InputError
// naming the log where the options do not suit it.
FilterDesign design_filter(const DeltaLog& log, const PrepareOptions& options);

// The joint states of every segment long enough to keep, on `threads`
// threads; throws delta::InputError where nothing is left to fit.
States joint_states(const DeltaLog& log, const FilterDesign& d, unsigned threads);

// What preprocessing the log did, up to its joint states.
PreprocessReport report_of(const DeltaLog& log, const FilterDesign& d,
                           const PrepareOptions& options, const States& s);

}  // namespace host_id::preprocessing
