#include "host_id/svg_plot.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace host_id {

namespace {

constexpr double kWidth = 960, kLeft = 70, kRight = 20, kPanelH = 150, kResidH = 60, kGap = 34;
constexpr double kScatterH = 150, kScatterGap = 60;  // residual against velocity
constexpr const char* kMeasured = "#1f4e9c";         // dark blue
constexpr const char* kPredicted = "#f5a55c";        // pale orange
constexpr const char* kResidual = "#d62728";

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

std::string esc(const std::string& s) {
  std::string r;
  for (char c : s) {
    if (c == '<')
      r += "&lt;";
    else if (c == '>')
      r += "&gt;";
    else if (c == '&')
      r += "&amp;";
    else
      r += c;
  }
  return r;
}

// Min/max decimation into at most `buckets` columns keeps every peak.
std::string polyline(const std::vector<double>& t, const std::vector<double>& y, double t0,
                     double t1, double lo, double hi, double x0, double w, double y0, double h,
                     const char* color, double width) {
  std::ostringstream s;
  s << "<polyline fill=\"none\" stroke=\"" << color << "\" stroke-width=\"" << width
    << "\" points=\"";
  const std::size_t n = y.size();
  const std::size_t buckets = 1200;
  const auto X = [&](double tt) { return x0 + (tt - t0) / (t1 - t0) * w; };
  const auto Y = [&](double v) { return y0 + h - (v - lo) / (hi - lo) * h; };
  if (n <= 2 * buckets) {
    for (std::size_t i = 0; i < n; ++i) s << num(X(t[i])) << ',' << num(Y(y[i])) << ' ';
  } else {
    for (std::size_t b = 0; b < buckets; ++b) {
      const std::size_t i0 = n * b / buckets, i1 = n * (b + 1) / buckets;
      const auto [mn, mx] = std::minmax_element(y.begin() + static_cast<std::ptrdiff_t>(i0),
                                                y.begin() + static_cast<std::ptrdiff_t>(i1));
      const bool min_first = mn < mx;
      const auto a = min_first ? mn : mx, c = min_first ? mx : mn;
      s << num(X(t[static_cast<std::size_t>(a - y.begin())])) << ',' << num(Y(*a)) << ' ';
      s << num(X(t[static_cast<std::size_t>(c - y.begin())])) << ',' << num(Y(*c)) << ' ';
    }
  }
  s << "\"/>\n";
  return s.str();
}

void axis(std::ostringstream& s, double x0, double w, double y0, double h, double lo, double hi,
          const std::string& label) {
  s << "<rect x=\"" << num(x0) << "\" y=\"" << num(y0) << "\" width=\"" << num(w) << "\" height=\""
    << num(h) << "\" fill=\"none\" stroke=\"#999\"/>\n";
  for (int i = 0; i <= 2; ++i) {
    const double v = lo + (hi - lo) * i / 2.0;
    const double y = y0 + h - h * i / 2.0;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3g", v);
    s << "<text x=\"" << num(x0 - 6) << "\" y=\"" << num(y + 4)
      << "\" font-size=\"11\" text-anchor=\"end\">" << buf << "</text>\n";
    s << "<line x1=\"" << num(x0) << "\" x2=\"" << num(x0 + w) << "\" y1=\"" << num(y) << "\" y2=\""
      << num(y) << "\" stroke=\"#eee\"/>\n";
  }
  s << "<text x=\"14\" y=\"" << num(y0 + h / 2) << "\" font-size=\"12\" transform=\"rotate(-90 14 "
    << num(y0 + h / 2) << ")\" text-anchor=\"middle\">" << esc(label) << "</text>\n";
}

// A step for about `target` ticks over span: 1, 2 or 5 times a power of ten.
double nice_step(double span, int target) {
  const double raw = span / target;
  const double decade = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * decade >= raw) return m * decade;
  }
  return 10.0 * decade;
}

// Vertical grid lines at round times, with their labels (in seconds)
// under the panel where `labels`.
void time_grid(std::ostringstream& s, double t0, double t1, double x0, double w, double y0,
               double h, bool labels) {
  const double step = nice_step(t1 - t0, 8);
  for (double t = std::ceil(t0 / step) * step; t <= t1 + 1e-9 * step; t += step) {
    const double x = x0 + (t - t0) / (t1 - t0) * w;
    s << "<line x1=\"" << num(x) << "\" x2=\"" << num(x) << "\" y1=\"" << num(y0) << "\" y2=\""
      << num(y0 + h) << "\" stroke=\"#eee\"/>\n";
    if (!labels) continue;
    char buf[32];
    std::snprintf(buf, sizeof buf, "%g", std::abs(t) < 1e-9 * step ? 0.0 : t);
    s << "<line x1=\"" << num(x) << "\" x2=\"" << num(x) << "\" y1=\"" << num(y0 + h) << "\" y2=\""
      << num(y0 + h + 4) << "\" stroke=\"#999\"/>\n";
    s << "<text x=\"" << num(x) << "\" y=\"" << num(y0 + h + 15)
      << "\" font-size=\"11\" text-anchor=\"middle\">" << buf << "</text>\n";
  }
  if (labels) {
    s << "<text x=\"" << num(x0 + w) << "\" y=\"" << num(y0 + h + 28)
      << "\" font-size=\"11\" text-anchor=\"end\">time [s]</text>\n";
  }
}

// The residual of one joint against its velocity: every sample as a dot
// (at most ~3000, evenly picked) and the mean residual in 40 velocity bins
// as a line. A friction model that misses the friction's shape leaves a
// pattern in the line (a step at zero speed, a slope, a dip near it).
void residual_against_velocity(std::ostringstream& s, const std::vector<double>& v,
                               const std::vector<double>& resid, double x0, double w, double y0,
                               double h, unsigned joint) {
  double vmax = 1e-9, rmax = 1e-12;
  for (std::size_t k = 0; k < v.size(); ++k) {
    vmax = std::max(vmax, std::abs(v[k]));
    rmax = std::max(rmax, std::abs(resid[k]));
  }
  s << "<rect x=\"" << num(x0) << "\" y=\"" << num(y0) << "\" width=\"" << num(w) << "\" height=\""
    << num(h) << "\" fill=\"none\" stroke=\"#999\"/>\n";
  s << "<line x1=\"" << num(x0 + w / 2) << "\" x2=\"" << num(x0 + w / 2) << "\" y1=\"" << num(y0)
    << "\" y2=\"" << num(y0 + h) << "\" stroke=\"#eee\"/>\n";
  s << "<line x1=\"" << num(x0) << "\" x2=\"" << num(x0 + w) << "\" y1=\"" << num(y0 + h / 2)
    << "\" y2=\"" << num(y0 + h / 2) << "\" stroke=\"#eee\"/>\n";
  const auto X = [&](double x) { return x0 + (x + vmax) / (2 * vmax) * w; };
  const auto Y = [&](double r) { return y0 + h / 2 - r / rmax * (h / 2); };
  s << "<path fill=\"none\" stroke=\"" << kResidual
    << "\" stroke-opacity=\"0.35\" stroke-width=\"1.5\" "
       "d=\"";
  const std::size_t stride = std::max<std::size_t>(1, v.size() / 3000);
  for (std::size_t k = 0; k < v.size(); k += stride) {
    s << 'M' << num(X(v[k])) << ',' << num(Y(resid[k])) << "h0.8";
  }
  s << "\"/>\n";
  constexpr std::size_t kBins = 40;
  std::vector<double> sum(kBins, 0.0);
  std::vector<std::size_t> count(kBins, 0);
  for (std::size_t k = 0; k < v.size(); ++k) {
    const auto b = std::min(kBins - 1, static_cast<std::size_t>((v[k] + vmax) / (2 * vmax) *
                                                                static_cast<double>(kBins)));
    sum[b] += resid[k];
    ++count[b];
  }
  s << "<polyline fill=\"none\" stroke=\"#000\" stroke-width=\"1.5\" points=\"";
  for (std::size_t b = 0; b < kBins; ++b) {
    if (count[b] < 10) continue;  // too few samples for a mean
    const double vc = -vmax + (static_cast<double>(b) + 0.5) * 2 * vmax / kBins;
    s << num(X(vc)) << ',' << num(Y(sum[b] / static_cast<double>(count[b]))) << ' ';
  }
  s << "\"/>\n";
  char buf[96];
  std::snprintf(buf, sizeof buf, "joint %u: residual (+-%.3g N m) vs qd (+-%.3g rad/s)", joint,
                rmax, vmax);
  s << "<text x=\"" << num(x0 + 2) << "\" y=\"" << num(y0 + h + 14) << "\" font-size=\"11\">" << buf
    << "</text>\n";
}

// Joint j's torque panel (measured and predicted) and its residual panel,
// from height y on; returns the height after them.
double joint_panels(std::ostringstream& s, const Prediction& p, unsigned j, double t0, double t1,
                    double w, double y) {
  double lo = std::numeric_limits<double>::infinity(), hi = -lo, rmax = 0;
  std::vector<double> resid(p.measured_Nm[j].size());
  for (std::size_t k = 0; k < resid.size(); ++k) {
    lo = std::min({lo, p.measured_Nm[j][k], p.predicted_Nm[j][k]});
    hi = std::max({hi, p.measured_Nm[j][k], p.predicted_Nm[j][k]});
    resid[k] = p.measured_Nm[j][k] - p.predicted_Nm[j][k];
    rmax = std::max(rmax, std::abs(resid[k]));
  }
  if (!(hi > lo)) {
    lo -= 1;
    hi += 1;
  }
  if (!(rmax > 0)) rmax = 1e-9;
  char label[64];
  std::snprintf(label, sizeof label, "tau%u [N m], RMSE %.4g", j + 1, p.rmse_filtered_Nm[j]);
  axis(s, kLeft, w, y, kPanelH, lo, hi, "tau" + std::to_string(j + 1) + " [N m]");
  // The prediction wide and pale underneath, the measurement thin on top:
  // where the fit is good both stay visible.
  s << polyline(p.t_s, p.predicted_Nm[j], t0, t1, lo, hi, kLeft, w, y, kPanelH, kPredicted, 3.0);
  s << polyline(p.t_s, p.measured_Nm[j], t0, t1, lo, hi, kLeft, w, y, kPanelH, kMeasured, 1.0);
  // The panel's name over the traces, with a white halo that keeps it legible.
  s << "<text x=\"" << num(kLeft + w - 4) << "\" y=\"" << num(y + 14)
    << "\" font-size=\"11\" text-anchor=\"end\" stroke=\"white\" stroke-width=\"3\" "
       "paint-order=\"stroke\">"
    << label << "</text>\n";
  time_grid(s, t0, t1, kLeft, w, y, kPanelH, false);
  y += kPanelH + 16;
  axis(s, kLeft, w, y, kResidH, -rmax, rmax, "resid. [N m]");
  s << polyline(p.t_s, resid, t0, t1, -rmax, rmax, kLeft, w, y, kResidH, kResidual, 0.8);
  time_grid(s, t0, t1, kLeft, w, y, kResidH, true);
  return y + kResidH + kGap;
}

// One log's block: its name, the three joints' panels, and the residuals
// against velocity; returns the height after it.
double log_block(std::ostringstream& s, const Prediction& p, double w, double y) {
  const std::string role = p.role == "fit"          ? "fit: the log the parameters come from"
                           : p.role == "validation" ? "validation: held out of the fit"
                                                    : "";
  s << "<text x=\"" << kLeft << "\" y=\"" << num(y + 16) << "\" font-size=\"14\">" << esc(p.log)
    << (role.empty() ? "" : " (" + role + ")") << "</text>\n";
  y += 30;
  const double t0 = p.t_s.empty() ? 0.0 : p.t_s.front();
  const double t1 = p.t_s.empty() ? 1.0 : std::max(p.t_s.back(), t0 + 1e-9);
  for (unsigned j = 0; j < 3; ++j) y = joint_panels(s, p, j, t0, t1, w, y);
  s << "<text x=\"" << kLeft << "\" y=\"" << num(y - 6) << "\" font-size=\"12\">"
    << "residual against joint velocity (dots: samples; line: mean in 40 velocity bins)"
    << "</text>\n";
  const double pw = (w - 2 * 20) / 3;
  for (unsigned j = 0; j < 3; ++j) {
    std::vector<double> resid(p.measured_Nm[j].size());
    for (std::size_t k = 0; k < resid.size(); ++k) {
      resid[k] = p.measured_Nm[j][k] - p.predicted_Nm[j][k];
    }
    residual_against_velocity(s, p.velocity_rad_s[j], resid, kLeft + j * (pw + 20), pw, y,
                              kScatterH, j + 1);
  }
  return y + kScatterH + kScatterGap;
}

// The three traces' colours and what they are, from (x, y) on.
void legend(std::ostringstream& s, double x, double y) {
  const struct {
    const char* color;
    double width;
    const char* label;
  } items[] = {{kMeasured, 1.5, "measured"},
               {kPredicted, 3.0, "predicted"},
               {kResidual, 1.5, "residual = measured - predicted"}};
  double at = x;
  for (const auto& it : items) {
    s << "<line x1=\"" << num(at) << "\" x2=\"" << num(at + 24) << "\" y1=\"" << num(y - 4)
      << "\" y2=\"" << num(y - 4) << "\" stroke=\"" << it.color << "\" stroke-width=\"" << it.width
      << "\"/>\n";
    s << "<text x=\"" << num(at + 30) << "\" y=\"" << num(y) << "\" font-size=\"12\">" << it.label
      << "</text>\n";
    at += 30 + 6.6 * static_cast<double>(std::string(it.label).size()) + 24;
  }
}

}  // namespace

std::string svg_torque_plot(const std::vector<Prediction>& logs, const std::string& title) {
  const double block = 3 * (kPanelH + 16 + kResidH + kGap) + 30 + kScatterH + kScatterGap;
  const double height = 56 + block * static_cast<double>(logs.size());
  const double w = kWidth - kLeft - kRight;
  std::ostringstream s;
  s << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << kWidth << "\" height=\""
    << num(height) << "\" font-family=\"sans-serif\">\n";
  s << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  s << "<text x=\"" << kLeft << "\" y=\"24\" font-size=\"16\">" << esc(title)
    << ": joint torques, filtered</text>\n";
  legend(s, kLeft, 46);
  double y = 56;
  for (const Prediction& p : logs) y = log_block(s, p, w, y);
  s << "</svg>\n";
  return s.str();
}

}  // namespace host_id
