#include "delta/trajectory_file.hpp"

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>

#include "delta/input_error.hpp"
#include "delta/json_text.hpp"
#include "delta/read_file.hpp"

namespace delta {

namespace {

constexpr const char* kFormat = "delta-trajectory/1";
constexpr unsigned kMaxHarmonics = 6;  // the controller's

using nlohmann::json;

class Reader {
 public:
  Reader(const json& j, const std::string& where) : j_(j), where_(where) {}

  [[noreturn]] void fail(const std::string& key, const std::string& what) const {
    throw InputError(where_ + ": " + key + ": " + what);
  }
  const json& need(const char* key) const {
    if (!j_.contains(key)) fail(key, "missing");
    return j_.at(key);
  }
  double number(const char* key, double lo, double hi) const {
    const json& v = need(key);
    if (!v.is_number()) fail(key, "must be a number");
    const double x = v.get<double>();
    if (!(x >= lo) || !(x <= hi)) {
      fail(key, "must be between " + json(lo).dump() + " and " + json(hi).dump() + " (got " +
                    v.dump() + ")");
    }
    return x;
  }
  // A 3 x n array of finite numbers; n is taken from the first row.
  std::array<std::vector<double>, 3> rows(const char* key) const {
    const json& v = need(key);
    if (!v.is_array() || v.size() != 3) fail(key, "must be three arrays, one per joint");
    std::array<std::vector<double>, 3> out;
    for (unsigned j = 0; j < 3; ++j) {
      const json& row = v[j];
      const std::string at = std::string(key) + "[" + std::to_string(j) + "]";
      if (!row.is_array()) fail(at, "must be an array of numbers");
      for (std::size_t k = 0; k < row.size(); ++k) {
        if (!row[k].is_number() || !std::isfinite(row[k].get<double>())) {
          fail(at + "[" + std::to_string(k) + "]", "must be a finite number");
        }
        out[j].push_back(row[k].get<double>());
      }
    }
    return out;
  }

 private:
  const json& j_;
  const std::string& where_;
};

}  // namespace

BlendedFourierTrajectory parse_trajectory(const std::string& text, const std::string& where) {
  const json j = parse_json(text, where);
  if (!j.is_object()) throw InputError(where + ": expected a JSON object");
  const Reader r(j, where);
  if (r.need("format") != kFormat) {
    r.fail("format", std::string("must be \"") + kFormat + "\" (got " + j["format"].dump() + ")");
  }
  if (r.need("kind") != "fourier") r.fail("kind", "must be \"fourier\" (the only kind so far)");
  for (const auto& [key, value] : j.items()) {
    (void)value;
    static const char* known[] = {"format",  "kind",   "base_frequency_hz", "blend_s",
                                  "periods", "q0_rad", "sin_amplitude_rad", "cos_amplitude_rad",
                                  "design"};
    bool ok = false;
    for (const char* k : known) ok = ok || key == k;
    if (!ok) r.fail(key, "unknown key");
  }
  BlendedFourierTrajectory t;
  t.fourier.base_frequency_hz = r.number("base_frequency_hz", 0.001, 5.0);
  t.blend_s = r.number("blend_s", 0.001, 60.0);
  const double periods = r.number("periods", 1, 1000);
  if (periods != std::floor(periods)) r.fail("periods", "must be a whole number");
  t.periods = static_cast<unsigned>(periods);
  const json& q0 = r.need("q0_rad");
  if (!q0.is_array() || q0.size() != 3) r.fail("q0_rad", "must be three numbers");
  for (unsigned j3 = 0; j3 < 3; ++j3) {
    if (!q0[j3].is_number() || !std::isfinite(q0[j3].get<double>()) ||
        std::abs(q0[j3].get<double>()) > 3.2) {
      r.fail("q0_rad[" + std::to_string(j3) + "]", "must be an angle in rad");
    }
    t.fourier.q0_rad[j3] = q0[j3].get<double>();
  }
  const auto a = r.rows("sin_amplitude_rad");
  const auto b = r.rows("cos_amplitude_rad");
  const std::size_t n = a[0].size();
  if (n < 1 || n > kMaxHarmonics) {
    r.fail("sin_amplitude_rad",
           "must have 1 to 6 harmonics per joint (got " + std::to_string(n) + ")");
  }
  const double w = 2.0 * std::numbers::pi * t.fourier.base_frequency_hz;
  for (unsigned jj = 0; jj < 3; ++jj) {
    if (a[jj].size() != n || b[jj].size() != n) {
      r.fail("cos_amplitude_rad", "every joint needs the same number of harmonics in both arrays");
    }
    // Position amplitudes A sin + B cos, as velocity amplitudes a = A k w, b = -B k w.
    for (std::size_t k = 0; k < n; ++k) {
      const double kw = static_cast<double>(k + 1) * w;
      t.fourier.a_rad_s[jj].push_back(a[jj][k] * kw);
      t.fourier.b_rad_s[jj].push_back(-b[jj][k] * kw);
    }
  }
  return t;
}

BlendedFourierTrajectory read_trajectory_file(const std::string& path) {
  return parse_trajectory(read_whole_file(path), path);
}

std::string format_trajectory(const BlendedFourierTrajectory& t, const std::string& design_json) {
  json j;
  j["format"] = kFormat;
  j["kind"] = "fourier";
  j["base_frequency_hz"] = t.fourier.base_frequency_hz;
  j["blend_s"] = t.blend_s;
  j["periods"] = t.periods;
  j["q0_rad"] = t.fourier.q0_rad;
  const double w = 2.0 * std::numbers::pi * t.fourier.base_frequency_hz;
  json a = json::array(), b = json::array();
  for (unsigned jj = 0; jj < 3; ++jj) {
    json ra = json::array(), rb = json::array();
    for (std::size_t k = 0; k < t.fourier.a_rad_s[jj].size(); ++k) {
      const double kw = static_cast<double>(k + 1) * w;
      ra.push_back(t.fourier.a_rad_s[jj][k] / kw);
      rb.push_back(-t.fourier.b_rad_s[jj][k] / kw);
    }
    a.push_back(ra);
    b.push_back(rb);
  }
  j["sin_amplitude_rad"] = a;
  j["cos_amplitude_rad"] = b;
  if (!design_json.empty()) j["design"] = json::parse(design_json);
  return j.dump(2) + "\n";
}

}  // namespace delta
