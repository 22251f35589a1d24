#include "host_id/preprocess.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <limits>
#include <sstream>
#include <vector>

#include "delta/input_error.hpp"
#include "host_id/parallel.hpp"
#include "host_id/signal.hpp"

namespace host_id {

namespace {

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
      << " Hz must lie between 0 and the Nyquist frequency " << 0.5 * fs << " Hz of this log";
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

// Samples per thread that pay for its start-up.
constexpr std::size_t kSamplesPerThread = 20000;

// Whether the times t[0..n) are evenly spaced about their median step h.
bool uniform_steps(const double* t, std::size_t n, double h) {
  double worst = 0.0;
  for (std::size_t i = 1; i < n; ++i) worst = std::max(worst, std::abs((t[i] - t[i - 1]) - h));
  return worst <= 1e-6 * h;
}

// The three joints' q of segment [b, e) of the log, filtered, into q
// (allocated by the caller, so that their memory returns to the caller's
// heap, not to a worker thread's).
void filter_joints(const DeltaLog& log, const FilterDesign& d, std::size_t b, std::size_t e,
                   std::array<std::vector<double>, 3>& q) {
  for (unsigned j = 0; j < 3; ++j) {
    std::copy(log.q[j].begin() + static_cast<std::ptrdiff_t>(b),
              log.q[j].begin() + static_cast<std::ptrdiff_t>(e), q[j].begin());
    filtfilt_in_place(d.state_filter, q[j], d.state_pad);
  }
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

// What preprocessing the log did, up to its joint states.
PreprocessReport report_of(const DeltaLog& log, const FilterDesign& d,
                           const PrepareOptions& options, const States& s) {
  PreprocessReport report;
  report.segments_used = s.segments.size();
  report.segments_dropped = s.segments_dropped;
  report.derivatives = describe(d, options, s);
  report.samples_in_log = log.size();
  report.sample_rate_hz = d.sample_rate_hz;
  report.state_cutoff_hz = d.logged_derivatives ? 0.0 : d.state.cutoff_hz;
  return report;
}

// Where each sample's three rows go. The samples kept after trimming go
// straight into the regression (rows 3i..3i+2 of kept sample i); the few
// trimmed at each segment end, which only the filter needs, go into a side
// buffer (rows 3t..3t+2 of trimmed sample t). So the regressor is built in
// its final place, with no full-size scratch copy.
class RowLayout {
 public:
  RowLayout(const std::vector<Segment>& segments, std::size_t trim) : trim_(trim) {
    for (const Segment& seg : segments) {
      kept_before_.push_back(kept_);
      side_before_.push_back(side_);
      kept_ += seg.end - seg.begin - 2 * trim;
      side_ += 2 * trim;
    }
  }
  std::size_t kept() const { return kept_; }
  std::size_t trimmed() const { return side_; }
  // Sample q of segment s (of length len): its kept index, or its side index
  // with on_side set.
  std::size_t place(std::size_t s, std::size_t q, std::size_t len, bool& on_side) const {
    on_side = q < trim_ || q >= len - trim_;
    if (!on_side) return kept_before_[s] + q - trim_;
    return side_before_[s] + (q < trim_ ? q : q - (len - 2 * trim_));
  }
  // Puts the rows of joints slower than slow_below_rad_s (|qd| at their
  // sample) after all the others, each group in time order. Without it,
  // joint j of kept sample i is row 3 i + j.
  void order_rows(const std::vector<Segment>& segments, const States& s, double slow_below_rad_s,
                  const std::string& log_name);
  // The regression's row of joint j of kept sample i.
  std::size_t row(std::size_t i, unsigned j) const {
    return rows_.empty() ? 3 * i + j : rows_[3 * i + j];
  }
  std::size_t fast_rows() const { return rows_.empty() ? 3 * kept_ : fast_; }

 private:
  std::size_t trim_;
  std::size_t kept_{0}, side_{0}, fast_{0};
  std::vector<std::size_t> kept_before_, side_before_;
  std::vector<std::uint32_t> rows_;  // [3 i + j]; empty: 3 i + j
};

void RowLayout::order_rows(const std::vector<Segment>& segments, const States& s,
                           double slow_below_rad_s, const std::string& log_name) {
  if (!(slow_below_rad_s > 0.0)) return;
  if (3 * kept_ > std::numeric_limits<std::uint32_t>::max()) {
    throw delta::InputError(log_name + ": " + std::to_string(kept_) +
                            " samples are more than a fit can order (at most " +
                            std::to_string(std::numeric_limits<std::uint32_t>::max() / 3) + ")");
  }
  rows_.resize(3 * kept_);
  // Marks first (1: fast), then each mark becomes its row.
  std::size_t i = 0;
  for (const Segment& seg : segments) {
    for (std::size_t k = seg.begin + trim_; k + trim_ < seg.end; ++k, ++i) {
      for (unsigned j = 0; j < 3; ++j) {
        const bool fast = std::abs(s.states[k].qd_rad_s[j]) >= slow_below_rad_s;
        rows_[3 * i + j] = fast ? 1u : 0u;
        fast_ += fast ? 1 : 0;
      }
    }
  }
  std::uint32_t next_fast = 0, next_slow = static_cast<std::uint32_t>(fast_);
  for (std::uint32_t& r : rows_) r = r != 0 ? next_fast++ : next_slow++;
}

// The regression's rows and tau in their places: psi column-major (the
// regression's own storage), the side rows row-major, tau of both alike.
struct RowStore {
  Eigen::MatrixXd& psi;
  Eigen::VectorXd& tau;
  std::vector<double> side_rows;  // 3 p per trimmed sample
  std::vector<double> side_tau;   // 3 per trimmed sample
  std::size_t p;
  double& at(bool on_side, std::size_t row, std::size_t c) {
    return on_side ? side_rows[row * p + c]
                   : psi(static_cast<Eigen::Index>(row), static_cast<Eigen::Index>(c));
  }
  double& tau_at(bool on_side, std::size_t row) {
    return on_side ? side_tau[row] : tau(static_cast<Eigen::Index>(row));
  }
};

// A kept sample's labels: its time, and its rows' joints, speeds and sample.
void label_kept(const States& s, std::size_t k, std::size_t i, const RowLayout& layout,
                Regression& r) {
  r.t_s[i] = s.t_s[k];
  for (unsigned j = 0; j < 3; ++j) {
    const std::size_t row = layout.row(i, j);
    r.joint[row] = static_cast<unsigned char>(j);
    r.velocity_rad_s[row] = s.states[k].qd_rad_s[j];
    r.sample[row] = i;
  }
}

// The unfiltered rows' moments are summed per chunk of this many samples,
// and the chunks' sums added in order: the same sums on any number of
// threads (a worker takes whole chunks).
constexpr std::size_t kMomentChunk = 1024;

// A worker's rows of the samples it builds together (at most a chunk):
// row-major, 3 p values per sample, the torque of each row, and the
// regressor row each kept row goes to. Built row by row in this small
// buffer and then copied out a column at a time: written straight into the
// column-major regressor, a sample's rows are stores to p columns far
// apart, which wait on memory.
struct ChunkRows {
  explicit ChunkRows(std::size_t p)
      : rows(3 * kMomentChunk * p), tau(3 * kMomentChunk), to_row(3 * kMomentChunk) {}
  std::vector<double> rows;
  std::vector<double> tau;
  std::vector<std::size_t> to_row;
};

// Where the rows of the samples go.
struct RowFill {
  const Model& model;
  const DeltaLog& log;
  const States& s;
  const RowLayout& layout;
  RowStore& store;
  Regression& r;

  // Samples [b, e) of segment si (no more than a chunk): their rows and
  // torques into their places, the columns not zero marked in nz (3 p, per
  // joint); the kept samples' labels, and their unfiltered rows into
  // `moments`. The first sample whose pose has no forward kinematics, or e.
  std::size_t samples(std::size_t si, std::size_t b, std::size_t e, ChunkRows& chunk,
                      unsigned char* nz, MeasuredMoments& moments) const {
    const std::size_t p = model.size();
    const Segment& seg = s.segments[si];
    const std::size_t len = seg.end - seg.begin;
    // The kept samples of a segment are one run between its trimmed ends.
    std::size_t kept_b = e, kept_e = e;
    for (std::size_t k = b; k < e; ++k) {
      double* rows = &chunk.rows[3 * (k - b) * p];
      if (model.rows(log.geometry, log.gravity_m_s2, s.states[k], rows) !=
          delta::KinematicsStatus::kOk) {
        return k;
      }
      for (unsigned j = 0; j < 3; ++j) chunk.tau[3 * (k - b) + j] = s.tau_Nm[k][j];
      bool side = false;
      const std::size_t i = layout.place(si, k - seg.begin, len, side);
      if (side) {
        put_aside(rows, &chunk.tau[3 * (k - b)], i, nz);
        continue;
      }
      kept_b = std::min(kept_b, k);
      kept_e = k + 1;
      label_kept(s, k, i, layout, r);
      for (unsigned j = 0; j < 3; ++j) chunk.to_row[3 * (k - b) + j] = layout.row(i, j);
    }
    if (kept_b < kept_e) put_kept(chunk, kept_b - b, kept_e - b, nz, moments);
    return e;
  }

  // A trimmed sample's three rows (row-major) and torques into the side
  // buffers at its side index i.
  void put_aside(const double* rows, const double* tau, std::size_t i, unsigned char* nz) const {
    const std::size_t p = model.size();
    for (unsigned j = 0; j < 3; ++j) {
      for (std::size_t c = 0; c < p; ++c) {
        const double v = rows[j * p + c];
        store.at(true, 3 * i + j, c) = v;
        nz[j * p + c] |= static_cast<unsigned char>(v != 0.0);
      }
      store.tau_at(true, 3 * i + j) = tau[j];
    }
  }

  // The kept samples [first, last) of the chunk: each column copied to the
  // regressor, tau alike, and each joint's rows into the moments.
  void put_kept(const ChunkRows& chunk, std::size_t first, std::size_t last, unsigned char* nz,
                MeasuredMoments& moments) const {
    const std::size_t p = model.size();
    for (std::size_t c = 0; c < p; ++c) {
      double* column = &store.psi(0, static_cast<Eigen::Index>(c));
      for (std::size_t t = 3 * first; t < 3 * last; ++t) {
        const double v = chunk.rows[t * p + c];
        column[chunk.to_row[t]] = v;
        nz[(t % 3) * p + c] |= static_cast<unsigned char>(v != 0.0);
      }
    }
    for (std::size_t t = 3 * first; t < 3 * last; ++t) {
      store.tau(static_cast<Eigen::Index>(chunk.to_row[t])) = chunk.tau[t];
    }
    const auto n = static_cast<Eigen::Index>(last - first);
    const auto pi = static_cast<Eigen::Index>(p);
    for (unsigned j = 0; j < 3; ++j) {
      // Joint j's rows as the columns of a p x n matrix, and its torques.
      const Eigen::Map<const Eigen::MatrixXd, 0, Eigen::OuterStride<>> rows(
          &chunk.rows[(3 * first + j) * p], pi, n, Eigen::OuterStride<>(3 * pi));
      const Eigen::Map<const Eigen::VectorXd, 0, Eigen::InnerStride<3>> tau(
          &chunk.tau[3 * first + j], n);
      moments.add(j, rows, tau);
    }
  }
};

// Each sample's regressor rows (forward kinematics, Jacobian, lambda) into
// their places, on `threads` threads; and tau alike. The kept samples'
// labels go into r (sized for them), their unfiltered rows into r.measured;
// nonzero[j p + c] says whether column c of joint j is anywhere other than
// zero.
void fill_rows(const Model& model, const DeltaLog& log, const States& s, const RowLayout& layout,
               RowStore& store, Regression& r, std::vector<unsigned char>& nonzero,
               unsigned threads) {
  const std::size_t n = s.size();
  const std::size_t p = model.size();
  const std::size_t workers = workers_for(n, threads, kSamplesPerThread);
  const std::size_t chunks = (n + kMomentChunk - 1) / kMomentChunk;
  const RowFill fill{model, log, s, layout, store, r};
  std::atomic<std::size_t> first_bad{n};
  std::vector<MeasuredMoments> chunk_moments(chunks);
  std::vector<std::vector<unsigned char>> nonzero_of(workers, std::vector<unsigned char>(3 * p));
  std::vector<ChunkRows> rows_of(workers, ChunkRows(p));
  // Chunk c on worker w, its moments summed alone, a segment's part at a
  // time. The workers take the next chunk left, so that a thread the
  // machine slows down does less; a chunk after a bad sample is skipped.
  const auto work = [&](std::size_t w, std::size_t c) {
    if (first_bad.load() < c * kMomentChunk) return;
    MeasuredMoments& moments = chunk_moments[c];
    moments.reset(p);
    for (std::size_t si = 0; si < s.segments.size(); ++si) {
      const std::size_t b = std::max(s.segments[si].begin, c * kMomentChunk);
      const std::size_t e = std::min(s.segments[si].end, (c + 1) * kMomentChunk);
      if (b >= e) continue;
      const std::size_t bad = fill.samples(si, b, e, rows_of[w], nonzero_of[w].data(), moments);
      if (bad == e) continue;
      std::size_t expected = first_bad.load();
      while (bad < expected && !first_bad.compare_exchange_weak(expected, bad)) {
      }
      return;
    }
  };
  run_tasks(chunks, workers, work);
  nonzero.assign(3 * p, 0);
  for (const auto& nz : nonzero_of) {
    for (std::size_t k = 0; k < nz.size(); ++k) nonzero[k] |= nz[k];
  }
  if (const std::size_t k = first_bad.load(); k < n) {
    const auto& q = s.states[k].q_rad;
    std::ostringstream m;
    m << log.name << ": sample at t = " << s.t_s[k] << " s: joint angles (" << q[0] << ", " << q[1]
      << ", " << q[2] << ") rad have "
      << "no forward kinematics for this geometry (unreachable or singular pose); "
      << "check the geometry metadata and the angle convention";
    throw delta::InputError(m.str());
  }
  r.measured.reset(p);  // every chunk was summed
  for (const MeasuredMoments& m : chunk_moments) r.measured.merge(m);
}

// Filters every column of Psi and tau per segment and joint with the same
// zero-phase filter as q ("parallel filtering": filtering is linear, so
// filt(tau) = filt(Psi) beta holds exactly), through the trimmed ends too.
// The series are independent: a task is one segment's (column, joint) pair
// that is not zero throughout (a joint's row is zero in the other joints'
// friction columns; nonzero from fill_rows), or one joint's tau, and the
// tasks are shared out over the threads.
void filter_columns(const FilterDesign& d, const std::vector<Segment>& segments,
                    const RowLayout& layout, RowStore& store,
                    const std::vector<unsigned char>& nonzero, std::size_t samples,
                    unsigned threads) {
  struct Task {
    std::size_t segment;
    unsigned joint;
    bool tau;
    std::size_t column;
  };
  std::vector<Task> tasks;
  for (std::size_t si = 0; si < segments.size(); ++si) {
    for (unsigned j = 0; j < 3; ++j) {
      tasks.push_back({si, j, true, 0});
      for (std::size_t c = 0; c < store.p; ++c) {
        if (nonzero[j * store.p + c]) tasks.push_back({si, j, false, c});
      }
    }
  }
  const auto run = [&](const Task& t) {
    const std::size_t len = segments[t.segment].end - segments[t.segment].begin;
    filtfilt_lanes(d.filter, len, 1, d.pad, [&](std::size_t q) {
      bool side = false;
      const std::size_t i = layout.place(t.segment, q, len, side);
      const std::size_t row = side ? 3 * i + t.joint : layout.row(i, t.joint);
      return t.tau ? &store.tau_at(side, row) : &store.at(side, row, t.column);
    });
  };
  const std::size_t workers = workers_for(samples, threads, kSamplesPerThread);
  run_tasks(tasks.size(), workers, [&](std::size_t, std::size_t k) { run(tasks[k]); });
}

// Where the states' samples go: the kept ones in the row order asked for
// (joints slower than slow_below_rad_s last), the trimmed ones aside.
RowLayout layout_of(const States& s, const FilterDesign& d, double slow_below_rad_s,
                    const std::string& log_name) {
  RowLayout layout(s.segments, d.trim);
  layout.order_rows(s.segments, s, slow_below_rad_s, log_name);
  return layout;
}

// The regression of the states: built in place, in the layout's row
// order, labelled, filtered, trimmed. With free_states the states are
// freed once the rows are built, before filtering needs its buffers.
Regression regression_of(const Model& model, const DeltaLog& log, States& s, const FilterDesign& d,
                         const RowLayout& layout, unsigned threads, bool free_states) {
  const std::size_t p = model.size();
  Regression r;
  r.psi.resize(static_cast<Eigen::Index>(3 * layout.kept()), static_cast<Eigen::Index>(p));
  r.tau.resize(static_cast<Eigen::Index>(3 * layout.kept()));
  RowStore store{r.psi, r.tau, std::vector<double>(3 * layout.trimmed() * p),
                 std::vector<double>(3 * layout.trimmed()), p};
  r.t_s.resize(layout.kept());
  r.joint.resize(3 * layout.kept());
  r.velocity_rad_s.resize(3 * layout.kept());
  r.sample.resize(3 * layout.kept());
  std::vector<unsigned char> nonzero;
  fill_rows(model, log, s, layout, store, r, nonzero, threads);
  for (unsigned j = 0; j < 3; ++j) {
    for (std::size_t c = 0; c < p; ++c) {
      if (nonzero[j * p + c]) r.joint_columns[j].push_back(static_cast<Eigen::Index>(c));
    }
  }
  r.joint_columns_of = static_cast<Eigen::Index>(p);
  const std::vector<Segment> segments = s.segments;
  const std::size_t samples = s.size();
  if (free_states) s = States{};
  if (!d.logged_derivatives) filter_columns(d, segments, layout, store, nonzero, samples, threads);
  return r;
}

// The columns of joint j's shape terms in the model's rows, and how many.
struct ShapeColumns {
  std::array<std::size_t, Model::kMaxShapeTerms> column{};
  std::size_t count{0};
};

// The shape terms of joint j over segment si: computed from each sample's
// velocity, filtered as fill_rows and filter_columns build and filter
// them (a lane's bits do not depend on the others), and the kept samples'
// values put into psi. Returns whether each term is anywhere nonzero.
std::array<bool, Model::kMaxShapeTerms> refill_shape_terms(const Model& model, const States& s,
                                                           const RowLayout& layout,
                                                           const FilterDesign& d, std::size_t si,
                                                           unsigned j, const ShapeColumns& shape,
                                                           Regression& r) {
  const Segment& seg = s.segments[si];
  const std::size_t n = seg.end - seg.begin;
  const std::size_t lanes = shape.count;
  std::vector<double> values(n * lanes);
  std::array<std::size_t, Model::kMaxShapeTerms> columns{};
  std::array<bool, Model::kMaxShapeTerms> nonzero{};
  for (std::size_t q = 0; q < n; ++q) {
    double* v = &values[q * lanes];
    model.shape_terms(j, s.states[seg.begin + q].qd_rad_s[j], columns.data(), v);
    for (std::size_t t = 0; t < lanes; ++t) nonzero[t] = nonzero[t] || v[t] != 0.0;
  }
  if (!d.logged_derivatives) {
    filtfilt_lanes(d.filter, n, lanes, d.pad, [&](std::size_t q) { return &values[q * lanes]; });
  }
  for (std::size_t q = 0; q < n; ++q) {
    bool side = false;
    const std::size_t i = layout.place(si, q, n, side);
    if (side) continue;
    const auto row = static_cast<Eigen::Index>(layout.row(i, j));
    for (std::size_t t = 0; t < lanes; ++t) {
      r.psi(row, static_cast<Eigen::Index>(shape.column[t])) = values[q * lanes + t];
    }
  }
  return nonzero;
}

// The columns of r that carry the friction's shape recomputed for model's
// shape, one task per segment and joint; the joints' nonzero columns
// follow.
void refill_shape_columns(const Model& model, const States& s, const RowLayout& layout,
                          const FilterDesign& d, unsigned threads, Regression& r) {
  std::array<ShapeColumns, 3> shape;
  std::array<double, Model::kMaxShapeTerms> unused{};
  for (unsigned j = 0; j < 3; ++j) {
    shape[j].count = model.shape_terms(j, 0.0, shape[j].column.data(), unused.data());
  }
  const std::size_t tasks = 3 * s.segments.size();
  std::vector<std::array<bool, Model::kMaxShapeTerms>> nonzero(tasks);
  run_tasks(tasks, workers_for(s.size(), threads, kSamplesPerThread / 3),
            [&](std::size_t, std::size_t task) {
              const auto j = static_cast<unsigned>(task % 3);
              nonzero[task] = refill_shape_terms(model, s, layout, d, task / 3, j, shape[j], r);
            });
  for (unsigned j = 0; j < 3; ++j) {
    std::vector<Eigen::Index>& columns = r.joint_columns[j];
    for (std::size_t t = 0; t < shape[j].count; ++t) {
      bool any = false;
      for (std::size_t task = j; task < tasks; task += 3) any = any || nonzero[task][t];
      const auto c = static_cast<Eigen::Index>(shape[j].column[t]);
      const auto at = std::lower_bound(columns.begin(), columns.end(), c);
      const bool listed = at != columns.end() && *at == c;
      if (any && !listed) columns.insert(at, c);
      if (!any && listed) columns.erase(at);
    }
  }
}

}  // namespace

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

namespace {

// The joint states of the log, then after_states() (which may free the
// log's samples: only its name, geometry and gravity are used after it),
// then the regression.
template <class AfterStates>
Preprocessed preprocess_with(const Model& model, const DeltaLog& log, const PrepareOptions& options,
                             unsigned threads, AfterStates after_states) {
  const FilterDesign design = design_filter(log, options);
  Preprocessed out;
  States states = joint_states(log, design, threads);
  out.report = report_of(log, design, options, states);
  after_states();
  const RowLayout layout = layout_of(states, design, options.slow_rows_last_below_rad_s, log.name);
  out.fast_rows = layout.fast_rows();
  out.regression = regression_of(model, log, states, design, layout, threads, true);
  return out;
}

}  // namespace

Preprocessed preprocess(const Model& model, const DeltaLog& log, const PrepareOptions& options,
                        unsigned threads) {
  return preprocess_with(model, log, options, threads, [] {});
}

Preprocessed preprocess_releasing(const Model& model, DeltaLog& log, const PrepareOptions& options,
                                  unsigned threads) {
  return preprocess_with(model, log, options, threads, [&log] { release_samples(log); });
}

// What a fit that searches the friction's shape keeps of its log: the
// filter, the joint states, the row layout, and the regression of the last
// shape asked for.
struct ShapePreprocess::Kept {
  Kept(const Model& model, const DeltaLog& log, const PrepareOptions& options, unsigned t)
      : design(design_filter(log, options)),
        states(joint_states(log, design, t)),
        layout(layout_of(states, design, options.slow_rows_last_below_rad_s, log.name)),
        threads(t) {
    out.report = report_of(log, design, options, states);
    out.fast_rows = layout.fast_rows();
    out.regression = regression_of(model, log, states, design, layout, t, false);
  }
  FilterDesign design;
  States states;
  RowLayout layout;
  unsigned threads;
  Preprocessed out;
};

ShapePreprocess::ShapePreprocess(const Model& model, const DeltaLog& log,
                                 const PrepareOptions& options, unsigned threads)
    : kept_(std::make_unique<Kept>(model, log, options, threads)) {}

ShapePreprocess::~ShapePreprocess() = default;

const Preprocessed& ShapePreprocess::with_shape(const Model& model) {
  refill_shape_columns(model, kept_->states, kept_->layout, kept_->design, kept_->threads,
                       kept_->out.regression);
  kept_->out.regression.measured = MeasuredMoments{};
  return kept_->out;
}

}  // namespace host_id
