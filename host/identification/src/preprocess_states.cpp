#include "preprocess_states.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

#include "delta/input_error.hpp"
#include "host_id/parallel.hpp"

namespace host_id::preprocessing {

namespace {

// The median of the n - 1 steps between the n times t[0..n-1].
double median_step(const double* t, std::size_t n) {
  std::vector<double> dt;
  dt.reserve(n);
  for (std::size_t i = 1; i < n; ++i) dt.push_back(t[i] - t[i - 1]);
  if (dt.empty()) return 0.0;
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  return dt[dt.size() / 2];
}

// q's cut-off: the one given, or chosen from the log's q, segment by
// segment (gaps split it), all three joints together.
StateCutoff state_cutoff(const DeltaLog& log, const PrepareOptions& options, double fs) {
  if (options.state_cutoff_hz) {
    const double fc = *options.state_cutoff_hz;
    if (!(fc > 0.0) || !(fc < 0.5 * fs)) {
      std::ostringstream s;
      s << log.name << ": the state filter's cut-off " << fc
        << " Hz must lie between 0 and the Nyquist frequency " << 0.5 * fs << " Hz of this log";
      throw delta::InputError(s.str());
    }
    return StateCutoff{fc, 0.0, false};
  }
  std::vector<std::size_t> bounds{0};
  for (const SampleGap& g : log.gaps) bounds.push_back(g.index);
  bounds.push_back(log.size());
  std::vector<Span> spans;
  for (unsigned j = 0; j < 3; ++j) {
    for (std::size_t k = 0; k + 1 < bounds.size(); ++k) {
      spans.push_back({log.q[j].data() + bounds[k], bounds[k + 1] - bounds[k]});
    }
  }
  return choose_state_cutoff(spans, fs, options.cutoff_hz);
}

}  // namespace

FilterDesign design_filter(const DeltaLog& log, const PrepareOptions& options) {
  (void)check_time_steps(log, options.time_steps);  // throws where they cannot be trusted
  FilterDesign d;
  d.nominal_steps = options.time_steps == TimeSteps::kNominal;
  const double h_median = median_step(log.t.data(), log.t.size());
  d.median_step_s = h_median;
  const double fs =
      log.sample_rate_hz ? *log.sample_rate_hz : (h_median > 0 ? 1.0 / h_median : 0.0);
  d.sample_rate_hz = fs;
  d.logged_derivatives = log.has_qd && log.has_qdd;
  if (d.logged_derivatives) return d;
  if (!(options.cutoff_hz > 0.0) || !(options.cutoff_hz < 0.5 * fs)) {
    std::ostringstream s;
    s << log.name << ": the filter cut-off " << options.cutoff_hz
      << " Hz must lie between 0 and the Nyquist frequency " << 0.5 * fs << " Hz of this log"
      << [&] {
           const std::string ms = milliseconds_hint(h_median, log.sample_rate_hz);
           return ms.empty() ? ms : "; " + ms;
         }();
    throw delta::InputError(s.str());
  }
  d.state = state_cutoff(log, options, fs);
  const double slowest_hz = std::min(options.cutoff_hz, d.state.cutoff_hz);
  d.trim = options.trim_samples >= 0 ? static_cast<std::size_t>(options.trim_samples)
                                     : static_cast<std::size_t>(std::ceil(3.0 * fs / slowest_hz));
  d.pad = static_cast<std::size_t>(std::ceil(3.0 * fs / options.cutoff_hz));
  d.filter = butterworth4_lowpass(options.cutoff_hz, fs);
  d.state_pad = static_cast<std::size_t>(std::ceil(3.0 * fs / d.state.cutoff_hz));
  d.state_filter = butterworth4_lowpass(d.state.cutoff_hz, fs);
  return d;
}

namespace {

// Whether the times t[0..n) are evenly spaced about their median step h.
bool uniform_steps(const double* t, std::size_t n, double h) {
  double worst = 0.0;
  for (std::size_t i = 1; i < n; ++i) worst = std::max(worst, std::abs((t[i] - t[i - 1]) - h));
  return worst <= 1e-6 * h;
}

// The three joints' q of segment [b, e) of the log, filtered side by side,
// into q (allocated by the caller).
void filter_joints(const DeltaLog& log, const FilterDesign& d, std::size_t b, std::size_t e,
                   std::array<std::vector<double>, 3>& q) {
  for (unsigned j = 0; j < 3; ++j) {
    std::copy(log.q[j].begin() + static_cast<std::ptrdiff_t>(b),
              log.q[j].begin() + static_cast<std::ptrdiff_t>(e), q[j].begin());
  }
  // Sample k of the three joints, side by side.
  struct Joints {
    std::array<std::vector<double>, 3>& q;
    std::size_t k;
    double& operator[](std::size_t j) const { return q[j][k]; }
  };
  filtfilt_lanes(d.state_filter, e - b, 3, d.state_pad, [&q](std::size_t k) {
    return Joints{q, k};
  });
}

// Where the joint states of segment [b, e) come from: the log's q, qd and
// qdd where it carries the derivatives, else the filtered q, differentiated
// at step h where the times are uniform.
struct JointSource {
  const DeltaLog& log;
  const FilterDesign& d;
  const std::array<std::vector<double>, 3>& filtered_q;
  std::size_t b, n;
  bool uniform;
  double h;

  // Sample i of the segment.
  void state(std::size_t i, delta::JointState& st) const {
    for (unsigned j = 0; j < 3; ++j) {
      if (d.logged_derivatives) {
        st.q_rad[j] = log.q[j][b + i];
        st.qd_rad_s[j] = log.qd[j][b + i];
        st.qdd_rad_s2[j] = log.qdd[j][b + i];
        continue;
      }
      const double* q = filtered_q[j].data();
      const Derivatives dq = uniform ? uniform_derivatives_at(q, n, h, i)
                                     : nonuniform_derivatives_at(log.t.data() + b, q, n, i);
      st.q_rad[j] = q[i];
      st.qd_rad_s[j] = dq.first;
      st.qdd_rad_s2[j] = dq.second;
    }
  }
};

// Room for segment [b, e)'s states at the end of out, and its raw torques
// (filtered later with the regressor's columns) and times.
void place_raw(const DeltaLog& log, std::size_t b, std::size_t e, States& out) {
  const std::size_t first = out.states.size();
  const std::size_t n = e - b;
  out.states.resize(first + n);
  out.tau_Nm.resize(first + n);
  for (std::size_t i = 0; i < n; ++i) {
    for (unsigned j = 0; j < 3; ++j) out.tau_Nm[first + i][j] = log.tau[j][b + i];
  }
  out.t_s.insert(out.t_s.end(), log.t.begin() + static_cast<std::ptrdiff_t>(b),
                 log.t.begin() + static_cast<std::ptrdiff_t>(e));
}

// q, qd, qdd and tau of one segment [b, e) of the log, appended to out. The
// joints' q are filtered on one thread while the states' memory is laid
// out on another; then the states are differentiated into place on all.
void append_segment(const DeltaLog& log, const FilterDesign& d, std::size_t b, std::size_t e,
                    unsigned threads, States& out) {
  const std::size_t n = e - b;
  const std::size_t first = out.states.size();
  out.segments.push_back({first, first + n, b});
  // The whole log's median step serves a log without gaps. The nominal
  // step is the declared rate's, else the segment's mean (unbiased by
  // jitter that does not accumulate, unlike the median of jittered steps).
  const double h = d.nominal_steps             ? (log.sample_rate_hz
                                                      ? 1.0 / *log.sample_rate_hz
                                                      : (log.t[e - 1] - log.t[b]) / static_cast<double>(n - 1))
                   : b == 0 && e == log.size() ? d.median_step_s
                                               : median_step(log.t.data() + b, n);
  const bool uniform =
      d.logged_derivatives || d.nominal_steps || uniform_steps(log.t.data() + b, n, h);
  out.any_nonuniform = out.any_nonuniform || !uniform;
  const std::size_t workers = workers_for(n, threads, kSamplesPerThread);
  std::array<std::vector<double>, 3> filtered_q;
  if (!d.logged_derivatives) {
    for (auto& q : filtered_q) q.resize(n);
  }
  run_tasks(2, workers, [&](std::size_t, std::size_t task) {
    if (task == 1) {
      place_raw(log, b, e, out);
    } else if (!d.logged_derivatives) {
      filter_joints(log, d, b, e, filtered_q);
    }
  });
  const JointSource source{log, d, filtered_q, b, n, uniform, h};
  // In pieces that the threads take as they come free.
  constexpr std::size_t kPiece = 4096;
  run_tasks((n + kPiece - 1) / kPiece, workers, [&](std::size_t, std::size_t piece) {
    for (std::size_t i = piece * kPiece; i < std::min(n, (piece + 1) * kPiece); ++i) {
      source.state(i, out.states[first + i]);
    }
  });
}

}  // namespace

States joint_states(const DeltaLog& log, const FilterDesign& d, unsigned threads) {
  States out;
  out.states.reserve(log.size());
  out.tau_Nm.reserve(log.size());
  out.t_s.reserve(log.size());
  std::vector<std::size_t> bounds{0};
  for (const SampleGap& g : log.gaps) bounds.push_back(g.index);
  bounds.push_back(log.size());
  for (std::size_t s = 0; s + 1 < bounds.size(); ++s) {
    if (bounds[s + 1] - bounds[s] < 2 * d.trim + 5) {
      ++out.segments_dropped;
      continue;
    }
    append_segment(log, d, bounds[s], bounds[s + 1], threads, out);
  }
  if (out.states.empty()) {
    std::ostringstream s;
    s << log.name << ": nothing left to fit: " << log.size() << " samples in " << bounds.size() - 1
      << " segment(s), each shorter than the " << 2 * d.trim + 5
      << " samples needed after trimming " << d.trim << " at each end";
    throw delta::InputError(s.str());
  }
  return out;
}

namespace {

std::string rad_text(double rad) {
  std::ostringstream t;
  t << std::setprecision(2) << rad << " rad RMS";
  return t.str();
}

std::string describe(const FilterDesign& d, const PrepareOptions& options, const States& s) {
  std::ostringstream text;
  if (d.logged_derivatives) {
    text << "qd and qdd from the log's columns (no filtering)";
  } else {
    text << "q low-pass filtered at " << std::setprecision(3) << d.state.cutoff_hz << " Hz ("
         << (options.state_cutoff_hz ? "as set"
             : d.state.from_content
                 ? "chosen from the log's spectrum; noise floor " + rad_text(d.state.noise_rms_rad)
                 : "too little motion or too short to choose from: --cutoff-hz")
         << "; 4th-order Butterworth, forward-backward), "
         << (s.any_nonuniform  ? "three-point differences on uneven time"
             : d.nominal_steps ? "five-point central differences at the nominal step (the "
                                 "timestamps' jitter set aside: --time-steps nominal)"
                               : "five-point central differences")
         << "; tau and the regressor filtered at " << options.cutoff_hz << " Hz; " << d.trim
         << " samples trimmed at each segment end";
  }
  return text.str();
}

}  // namespace

PreprocessReport report_of(const DeltaLog& log, const FilterDesign& d,
                           const PrepareOptions& options, const States& s) {
  PreprocessReport report;
  report.segments_used = s.segments.size();
  report.segments_dropped = s.segments_dropped;
  report.derivatives = describe(d, options, s);
  report.samples_in_log = log.size();
  report.sample_rate_hz = d.sample_rate_hz;
  report.state_cutoff_hz = d.logged_derivatives ? 0.0 : d.state.cutoff_hz;
  report.ranges = ranges_of(s.states);
  return report;
}

}  // namespace host_id::preprocessing

namespace host_id {

using preprocessing::design_filter;
using preprocessing::FilterDesign;
using preprocessing::joint_states;
using preprocessing::report_of;
using preprocessing::Segment;
using preprocessing::States;

PreparedStates prepare_states(const DeltaLog& log, const PrepareOptions& options) {
  const FilterDesign design = design_filter(log, options);
  const States s = joint_states(log, design, 1);
  PreparedStates out;
  out.report = report_of(log, design, options, s);
  for (const Segment& seg : s.segments) {
    for (std::size_t k = seg.begin + design.trim; k + design.trim < seg.end; ++k) {
      out.log_index.push_back(seg.log_begin + (k - seg.begin));
      out.states.push_back(s.states[k]);
    }
  }
  return out;
}

}  // namespace host_id
