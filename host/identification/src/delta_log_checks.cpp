// What a delta-log's reader tells its user beyond errors: the time steps'
// spread (refused where it would bias the fit) and the log's warnings.
#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <ostream>
#include <sstream>
#include <utility>
#include <vector>

#include "delta/input_error.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {

TimeStepSpread time_step_spread(const DeltaLog& log) {
  TimeStepSpread out;
  // The steps within segments (a gap's step left out), visited in order.
  const auto each_step = [&log](auto&& visit) {
    std::size_t gap = 0;
    for (std::size_t i = 1; i < log.size(); ++i) {
      while (gap < log.gaps.size() && log.gaps[gap].index < i) ++gap;
      if (gap < log.gaps.size() && log.gaps[gap].index == i) continue;
      visit(log.t[i] - log.t[i - 1]);
    }
  };
  // The median and the spread from at most kKept evenly spaced steps (an
  // hour-long log's steps would take tens of megabytes); the largest
  // departure from all of them.
  constexpr std::size_t kKept = 1 << 16;
  const std::size_t stride = log.size() / kKept + 1;
  std::vector<double> dt;
  std::size_t k = 0;
  each_step([&](double step) {
    if (k++ % stride == 0) dt.push_back(step);
  });
  if (dt.empty()) return out;
  const auto median = [](std::vector<double>& v) {
    const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
    std::nth_element(v.begin(), mid, v.end());
    return *mid;
  };
  out.median_s = median(dt);
  if (!(out.median_s > 0)) return out;
  for (double& step : dt) step = std::abs(step - out.median_s);
  out.spread = 1.4826 * median(dt) / out.median_s;
  each_step([&](double step) {
    out.largest = std::max(out.largest, std::abs(step - out.median_s) / out.median_s);
  });
  return out;
}

std::string check_time_steps(const DeltaLog& log, TimeSteps mode) {
  if (mode != TimeSteps::kCheck || (log.has_qd && log.has_qdd)) return "";
  const TimeStepSpread s = time_step_spread(log);
  if (s.spread <= kTimeStepWarning) return "";
  std::ostringstream text;
  text << "the time steps spread by " << std::setprecision(2) << 100.0 * s.spread
       << " % of the median step (" << std::setprecision(4) << 1e3 * s.median_s
       << " ms; the largest departs by " << std::setprecision(2) << 100.0 * s.largest << " %)";
  if (s.spread <= kTimeStepError) {
    return text.str() +
           ": q is differentiated on these times; if the samples were taken "
           "evenly, --time-steps nominal is more accurate";
  }
  text << ": differentiated on these times, q's derivatives are noisy and bias the fit "
          "(docs/preprocessing.md, \"Timestamps\"). If the samples were taken evenly and only "
          "their timestamps jitter (a logger on a host), use --time-steps nominal; if they were "
          "taken at these times, use --time-steps as-logged";
  throw delta::InputError(log.name + ": " + text.str());
}

std::string milliseconds_hint(double median_step_s, std::optional<double> declared_rate_hz) {
  const bool thousandfold =
      declared_rate_hz && std::abs(median_step_s * *declared_rate_hz / 1000.0 - 1.0) < 0.05;
  const bool undeclared_slow = !declared_rate_hz && median_step_s >= 0.5 && median_step_s <= 20.0;
  if (!thousandfold && !undeclared_slow) return "";
  return "t looks like milliseconds (the median step is " + format_number(median_step_s) +
         "): the format's t is in seconds (docs/log-format.md), so divide the t column by 1000";
}

std::vector<std::pair<double, double>> torque_stalls(const DeltaLog& log) {
  std::array<double, 3> floor{};
  for (unsigned j = 0; j < 3; ++j) {
    double ss = 0;
    for (const double v : log.tau[j]) ss += v * v;
    floor[j] = kStallTorqueFraction * std::sqrt(ss / static_cast<double>(log.size()));
  }
  std::vector<std::pair<double, double>> out;
  std::size_t start = 0;
  bool in_stall = false;
  for (std::size_t k = 0; k <= log.size(); ++k) {
    const bool still = k < log.size() && std::abs(log.tau[0][k]) <= floor[0] &&
                       std::abs(log.tau[1][k]) <= floor[1] && std::abs(log.tau[2][k]) <= floor[2];
    if (still && !in_stall) start = k;
    if (!still && in_stall && log.t[k - 1] - log.t[start] >= kStallMinSeconds) {
      out.emplace_back(log.t[start], log.t[k - 1]);
    }
    in_stall = still;
  }
  return out;
}

void warn_about_log(std::ostream& err, const DeltaLog& log, TimeSteps mode) {
  for (const auto& [from, to] : torque_stalls(log)) {
    err << log.name << ": warning: from t = " << from << " s to " << to
        << " s every joint's torque is 0: a delta's arms always carry its weight, so the drives "
           "gave no torque there (disabled, or faulted, mid-run?); its samples bias the fit: cut "
           "the span out of the log (docs/log-format.md, 'Gaps')\n";
  }
  if (const std::string w = check_time_steps(log, mode); !w.empty()) {
    err << log.name << ": warning: " << w << "\n";
  }
  if (log.has_qd != log.has_qdd) {
    const char* given = log.has_qd ? "qd1..qd3" : "qdd1..qdd3";
    const char* missing = log.has_qd ? "qdd1..qdd3" : "qd1..qd3";
    err << log.name << ": warning: the log has " << given << " but not " << missing << ", so "
        << given << " are not used: q is filtered and differentiated (give both, or "
        << "neither; docs/log-format.md)\n";
  }
  // Columns the format documents are no news: the recorder's motor
  // currents i1..i3 (kept, not used) and the arm side's encoders qa1..qa3
  // (fit --elastic and an elastic model's predictions read them).
  std::string names;
  for (const auto& [name, series] : log.extra_columns) {
    if (name == "i1" || name == "i2" || name == "i3") continue;
    if (name == "qa1" || name == "qa2" || name == "qa3") continue;
    names += (names.empty() ? "" : ", ") + name;
  }
  if (!names.empty()) {
    err << log.name << ": warning: column(s) " << names
        << " are not used by the model (docs/log-format.md lists the columns it reads)\n";
  }
  const std::size_t shown = std::min(log.gaps.size(), kGapWarningsShown);
  for (std::size_t i = 0; i < shown; ++i) {
    const SampleGap& g = log.gaps[i];
    err << log.name << ":" << g.line << ": warning: " << g.what
        << "; segments are fitted separately\n";
  }
  if (log.gaps.size() > shown) {
    err << log.name << ": warning: ... and " << log.gaps.size() - shown << " more gaps, up to line "
        << log.gaps.back().line << "\n";
  }
}

}  // namespace host_id
