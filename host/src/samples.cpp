#include "host_id/samples.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "delta/input_error.hpp"
#include "host_id/signal.hpp"

namespace host_id {

namespace {

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

}  // namespace

Samples prepare_samples(const DeltaLog& log, const PrepareOptions& options) {
  Samples out;
  out.samples_in_log = log.size();
  const double h_median = median_step(log.t);
  const double fs =
      log.sample_rate_hz ? *log.sample_rate_hz : (h_median > 0 ? 1.0 / h_median : 0.0);
  out.sample_rate_hz = fs;
  const bool logged = log.has_qd && log.has_qdd;
  if (!logged) {
    if (!(options.cutoff_hz > 0.0) || !(options.cutoff_hz < 0.5 * fs)) {
      std::ostringstream s;
      s << log.name << ": the filter cut-off " << options.cutoff_hz
        << " Hz must lie between 0 and the Nyquist frequency " << 0.5 * fs << " Hz of this log";
      throw delta::InputError(s.str());
    }
  }
  const std::size_t trim =
      logged ? 0
             : (options.trim_samples >= 0
                    ? static_cast<std::size_t>(options.trim_samples)
                    : static_cast<std::size_t>(std::ceil(3.0 * fs / options.cutoff_hz)));
  const std::size_t pad =
      static_cast<std::size_t>(std::ceil(3.0 * fs / std::max(options.cutoff_hz, 1e-9)));
  const auto filter =
      logged ? std::array<Biquad, 2>{} : butterworth4_lowpass(options.cutoff_hz, fs);

  // Segment boundaries: the gaps.
  std::vector<std::size_t> bounds{0};
  for (const SampleGap& g : log.gaps) bounds.push_back(g.index);
  bounds.push_back(log.size());

  bool any_nonuniform = false;
  for (std::size_t s = 0; s + 1 < bounds.size(); ++s) {
    const std::size_t b = bounds[s], e = bounds[s + 1];
    const std::size_t n = e - b;
    if (n < 2 * trim + 5) {
      ++out.segments_dropped;
      continue;
    }
    ++out.segments_used;
    out.segments.push_back({out.states.size(), out.states.size() + n});
    const std::vector<double> t = slice(log.t, b, e);
    std::array<std::vector<double>, 3> q, qd, qdd, tau;
    if (logged) {
      for (unsigned j = 0; j < 3; ++j) {
        q[j] = slice(log.q[j], b, e);
        qd[j] = slice(log.qd[j], b, e);
        qdd[j] = slice(log.qdd[j], b, e);
        tau[j] = slice(log.tau[j], b, e);
      }
    } else {
      const double h = median_step(t);
      double worst = 0.0;
      for (std::size_t i = 1; i < n; ++i) worst = std::max(worst, std::abs((t[i] - t[i - 1]) - h));
      const bool uniform = worst <= 1e-6 * h;
      any_nonuniform = any_nonuniform || !uniform;
      for (unsigned j = 0; j < 3; ++j) {
        q[j] = filtfilt(filter, slice(log.q[j], b, e), pad);
        tau[j] = slice(log.tau[j], b, e);  // filtered with the regressor's columns
        if (uniform) {
          differentiate_uniform(q[j], h, qd[j], qdd[j]);
        } else {
          differentiate_nonuniform(t, q[j], qd[j], qdd[j]);
        }
      }
    }
    for (std::size_t i = 0; i < n; ++i) {
      delta::JointState st;
      delta::Joint3 tq{};
      for (unsigned j = 0; j < 3; ++j) {
        st.q_rad[j] = q[j][i];
        st.qd_rad_s[j] = qd[j][i];
        st.qdd_rad_s2[j] = qdd[j][i];
        tq[j] = tau[j][i];
      }
      out.states.push_back(st);
      out.tau_Nm.push_back(tq);
      out.t_s.push_back(t[i]);
    }
  }
  out.parallel_filter = !logged;
  out.filter = filter;
  out.pad = pad;
  out.trim = trim;
  if (out.states.empty()) {
    std::ostringstream s;
    s << log.name << ": nothing left to fit: " << log.size() << " samples in " << bounds.size() - 1
      << " segment(s), each shorter than the " << 2 * trim + 5 << " samples needed after trimming "
      << trim << " at each end";
    throw delta::InputError(s.str());
  }
  std::ostringstream d;
  if (logged) {
    d << "qd and qdd from the log's columns (no filtering)";
  } else {
    d << "q low-pass filtered at " << options.cutoff_hz
      << " Hz (4th-order Butterworth, forward-backward), "
      << (any_nonuniform ? "three-point differences on uneven time"
                         : "five-point central differences")
      << "; tau and the regressor filtered alike; " << trim
      << " samples trimmed at each segment end";
  }
  out.derivatives = d.str();
  return out;
}

}  // namespace host_id
