#include "host_id/preprocess.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <sstream>
#include <thread>
#include <vector>

#include "delta/input_error.hpp"
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
  std::array<Biquad, 2> filter{};
  std::size_t pad{0};   // reflected samples at each end of a filtered series
  std::size_t trim{0};  // samples dropped at each segment end after filtering
  double sample_rate_hz{0};
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

double median_step(const std::vector<double>& t) {
  std::vector<double> dt;
  dt.reserve(t.size());
  for (std::size_t i = 1; i < t.size(); ++i) dt.push_back(t[i] - t[i - 1]);
  if (dt.empty()) return 0.0;
  std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
  return dt[dt.size() / 2];
}

std::vector<double> slice(const std::vector<double>& v, std::size_t b, std::size_t e) {
  return std::vector<double>(v.begin() + static_cast<std::ptrdiff_t>(b),
                             v.begin() + static_cast<std::ptrdiff_t>(e));
}

FilterDesign design_filter(const DeltaLog& log, const PrepareOptions& options) {
  FilterDesign d;
  const double h_median = median_step(log.t);
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
  d.trim = options.trim_samples >= 0
               ? static_cast<std::size_t>(options.trim_samples)
               : static_cast<std::size_t>(std::ceil(3.0 * fs / options.cutoff_hz));
  d.pad = static_cast<std::size_t>(std::ceil(3.0 * fs / options.cutoff_hz));
  d.filter = butterworth4_lowpass(options.cutoff_hz, fs);
  return d;
}

// q, qd, qdd and tau of one segment [b, e) of the log, appended to out.
void append_segment(const DeltaLog& log, const FilterDesign& d, std::size_t b, std::size_t e,
                    States& out) {
  const std::size_t n = e - b;
  out.segments.push_back({out.states.size(), out.states.size() + n, b});
  const std::vector<double> t = slice(log.t, b, e);
  std::array<std::vector<double>, 3> q, qd, qdd;
  bool uniform = true;
  double h = 0.0;
  if (!d.logged_derivatives) {
    h = median_step(t);
    double worst = 0.0;
    for (std::size_t i = 1; i < n; ++i) worst = std::max(worst, std::abs((t[i] - t[i - 1]) - h));
    uniform = worst <= 1e-6 * h;
    out.any_nonuniform = out.any_nonuniform || !uniform;
  }
  for (unsigned j = 0; j < 3; ++j) {
    if (d.logged_derivatives) {
      q[j] = slice(log.q[j], b, e);
      qd[j] = slice(log.qd[j], b, e);
      qdd[j] = slice(log.qdd[j], b, e);
    } else {
      q[j] = filtfilt(d.filter, slice(log.q[j], b, e), d.pad);
      if (uniform) {
        differentiate_uniform(q[j], h, qd[j], qdd[j]);
      } else {
        differentiate_nonuniform(t, q[j], qd[j], qdd[j]);
      }
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    delta::JointState st;
    for (unsigned j = 0; j < 3; ++j) {
      st.q_rad[j] = q[j][i];
      st.qd_rad_s[j] = qd[j][i];
      st.qdd_rad_s2[j] = qdd[j][i];
    }
    out.states.push_back(st);
    // tau stays raw here: it is filtered with the regressor's columns.
    out.tau_Nm.push_back({log.tau[0][b + i], log.tau[1][b + i], log.tau[2][b + i]});
    out.t_s.push_back(t[i]);
  }
}

States joint_states(const DeltaLog& log, const FilterDesign& d) {
  States out;
  std::vector<std::size_t> bounds{0};
  for (const SampleGap& g : log.gaps) bounds.push_back(g.index);
  bounds.push_back(log.size());
  for (std::size_t s = 0; s + 1 < bounds.size(); ++s) {
    if (bounds[s + 1] - bounds[s] < 2 * d.trim + 5) {
      ++out.segments_dropped;
      continue;
    }
    append_segment(log, d, bounds[s], bounds[s + 1], out);
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

std::string describe(const FilterDesign& d, const PrepareOptions& options, const States& s) {
  std::ostringstream text;
  if (d.logged_derivatives) {
    text << "qd and qdd from the log's columns (no filtering)";
  } else {
    text << "q low-pass filtered at " << options.cutoff_hz
         << " Hz (4th-order Butterworth, forward-backward), "
         << (s.any_nonuniform ? "three-point differences on uneven time"
                              : "five-point central differences")
         << "; tau and the regressor filtered alike; " << d.trim
         << " samples trimmed at each segment end";
  }
  return text.str();
}

// How many threads for n samples: below ~20k samples a second thread does
// not pay for its start-up.
std::size_t workers_for(std::size_t n, unsigned threads) {
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  return std::min<std::size_t>(threads, std::max<std::size_t>(1, n / 20000));
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

 private:
  std::size_t trim_;
  std::size_t kept_{0}, side_{0};
  std::vector<std::size_t> kept_before_, side_before_;
};

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
  // Columns first.. of a row, as lanes: psi's are a column apart, the side
  // rows' next to each other.
  LaneRef lanes(bool on_side, std::size_t row, std::size_t first) {
    return on_side ? LaneRef{&side_rows[row * p + first], 1}
                   : LaneRef{&psi(static_cast<Eigen::Index>(row), static_cast<Eigen::Index>(first)),
                             psi.outerStride()};
  }
  // tau of a sample's three rows (joints 1..3), as lanes.
  LaneRef tau_lanes(bool on_side, std::size_t row) {
    return on_side ? LaneRef{&side_tau[row], 1} : LaneRef{&tau(static_cast<Eigen::Index>(row)), 1};
  }
};

// Each sample's regressor rows (forward kinematics, Jacobian, lambda) into
// their places, on `threads` threads; and tau alike.
// The kept samples' unfiltered rows also go into `measured`.
void fill_rows(const Model& model, const DeltaLog& log, const States& s, const RowLayout& layout,
               RowStore& store, MeasuredMoments& measured, unsigned threads) {
  const std::size_t n = s.size();
  const std::size_t p = model.size();
  const std::size_t workers = workers_for(n, threads);
  std::atomic<std::size_t> first_bad{n};
  std::vector<MeasuredMoments> moments(workers);
  for (MeasuredMoments& m : moments) m.reset(p);
  const auto work = [&](std::size_t w) {
    std::vector<double> rows(3 * p);
    for (std::size_t si = 0; si < s.segments.size(); ++si) {
      const Segment& seg = s.segments[si];
      const std::size_t len = seg.end - seg.begin;
      const std::size_t b = std::max(seg.begin, n * w / workers);
      const std::size_t e = std::min(seg.end, n * (w + 1) / workers);
      for (std::size_t k = b; k < e; ++k) {
        if (model.rows(log.geometry, log.gravity_m_s2, s.states[k], rows.data()) !=
            delta::KinematicsStatus::kOk) {
          std::size_t expected = first_bad.load();
          while (k < expected && !first_bad.compare_exchange_weak(expected, k)) {
          }
          return;
        }
        bool side = false;
        const std::size_t i = layout.place(si, k - seg.begin, len, side);
        for (unsigned j = 0; j < 3; ++j) {
          for (std::size_t c = 0; c < p; ++c) store.at(side, 3 * i + j, c) = rows[j * p + c];
          store.tau_at(side, 3 * i + j) = s.tau_Nm[k][j];
          if (!side) moments[w].add(j, &rows[j * p], s.tau_Nm[k][j]);
        }
      }
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work, w);
  work(0);
  for (auto& t : pool) t.join();
  measured = std::move(moments[0]);
  for (std::size_t w = 1; w < workers; ++w) measured.merge(moments[w]);
  if (const std::size_t k = first_bad.load(); k < n) {
    const auto& q = s.states[k].q_rad;
    std::ostringstream m;
    m << log.name << ": sample at t = " << s.t_s[k] << " s: joint angles (" << q[0] << ", " << q[1]
      << ", " << q[2] << ") rad have "
      << "no forward kinematics for this geometry (unreachable or singular pose); "
      << "check the geometry metadata and the angle convention";
    throw delta::InputError(m.str());
  }
}

// Filters every column of Psi and tau per segment and joint with the same
// zero-phase filter as q ("parallel filtering": filtering is linear, so
// filt(tau) = filt(Psi) beta holds exactly), through the trimmed ends too.
// The series are independent: blocks of up to four columns of one joint
// (and tau's three joints) are shared out over the threads.
void filter_columns(const FilterDesign& d, const std::vector<Segment>& segments,
                    const RowLayout& layout, RowStore& store, std::size_t samples,
                    unsigned threads) {
  struct Task {
    std::size_t segment;
    unsigned joint;     // 3: tau's three joints
    std::size_t first;  // column
    std::size_t lanes;
  };
  std::vector<Task> tasks;
  for (std::size_t si = 0; si < segments.size(); ++si) {
    for (unsigned j = 0; j < 3; ++j) {
      for (std::size_t c = 0; c < store.p; c += FiltfiltBlock::kMaxLanes) {
        tasks.push_back({si, j, c, std::min(FiltfiltBlock::kMaxLanes, store.p - c)});
      }
    }
    tasks.push_back({si, 3, 0, 3});
  }
  const auto run = [&](const Task& t) {
    const std::size_t si = t.segment;
    const std::size_t len = segments[si].end - segments[si].begin;
    filtfilt_lanes(d.filter, len, t.lanes, d.pad, [&](std::size_t q) {
      bool side = false;
      const std::size_t i = layout.place(si, q, len, side);
      return t.joint == 3 ? store.tau_lanes(side, 3 * i)
                          : store.lanes(side, 3 * i + t.joint, t.first);
    });
  };
  std::atomic<std::size_t> next{0};
  const auto work = [&] {
    for (std::size_t k = next++; k < tasks.size(); k = next++) run(tasks[k]);
  };
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < workers_for(samples, threads); ++w) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
}

// The rows' joints, speeds, samples and times.
void label_rows(const States& s, const RowLayout& layout, std::size_t trim, Regression& r) {
  r.t_s.reserve(layout.kept());
  r.joint.reserve(3 * layout.kept());
  r.velocity_rad_s.reserve(3 * layout.kept());
  r.sample.reserve(3 * layout.kept());
  for (const Segment& seg : s.segments) {
    for (std::size_t k = seg.begin + trim; k + trim < seg.end; ++k) {
      const std::size_t i = r.t_s.size();
      r.t_s.push_back(s.t_s[k]);
      for (unsigned j = 0; j < 3; ++j) {
        r.joint.push_back(static_cast<unsigned char>(j));
        r.velocity_rad_s.push_back(s.states[k].qd_rad_s[j]);
        r.sample.push_back(i);
      }
    }
  }
}

// The regression of the states: built in place, labelled, filtered,
// trimmed. The states are freed once the rows are built, before filtering
// needs its buffers.
Regression regression_of(const Model& model, const DeltaLog& log, States&& s, const FilterDesign& d,
                         unsigned threads) {
  const std::size_t p = model.size();
  const RowLayout layout(s.segments, d.trim);
  Regression r;
  r.psi.resize(static_cast<Eigen::Index>(3 * layout.kept()), static_cast<Eigen::Index>(p));
  r.tau.resize(static_cast<Eigen::Index>(3 * layout.kept()));
  RowStore store{r.psi, r.tau, std::vector<double>(3 * layout.trimmed() * p),
                 std::vector<double>(3 * layout.trimmed()), p};
  fill_rows(model, log, s, layout, store, r.measured, threads);
  label_rows(s, layout, d.trim, r);
  const std::vector<Segment> segments = s.segments;
  const std::size_t samples = s.size();
  s = States{};
  if (!d.logged_derivatives) filter_columns(d, segments, layout, store, samples, threads);
  return r;
}

}  // namespace

PreparedStates prepare_states(const DeltaLog& log, const PrepareOptions& options) {
  const FilterDesign design = design_filter(log, options);
  const States s = joint_states(log, design);
  PreparedStates out;
  out.report.segments_used = s.segments.size();
  out.report.segments_dropped = s.segments_dropped;
  out.report.derivatives = describe(design, options, s);
  out.report.samples_in_log = log.size();
  out.report.sample_rate_hz = design.sample_rate_hz;
  for (const Segment& seg : s.segments) {
    for (std::size_t k = seg.begin + design.trim; k + design.trim < seg.end; ++k) {
      out.log_index.push_back(seg.log_begin + (k - seg.begin));
      out.states.push_back(s.states[k]);
    }
  }
  return out;
}

Preprocessed preprocess(const Model& model, const DeltaLog& log, const PrepareOptions& options,
                        unsigned threads) {
  const FilterDesign design = design_filter(log, options);
  Preprocessed out;
  States states = joint_states(log, design);
  out.report.segments_used = states.segments.size();
  out.report.segments_dropped = states.segments_dropped;
  out.report.derivatives = describe(design, options, states);
  out.regression = regression_of(model, log, std::move(states), design, threads);
  out.report.samples_in_log = log.size();
  out.report.sample_rate_hz = design.sample_rate_hz;
  return out;
}

}  // namespace host_id
