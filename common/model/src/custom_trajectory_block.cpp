#include "delta/custom_trajectory_block.hpp"

#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "delta/input_error.hpp"

namespace delta {

namespace mb = delta::modbus;

namespace {

// Stores `value` (in the register's unit) into the block, rounded to its
// resolution; InputError where it does not fit.
void put(std::vector<std::uint16_t>& block, const mb::Register& r, double value, double lo,
         double hi) {
  const double raw = std::round(value * r.scale_den / r.scale_num);
  if (!std::isfinite(value) || !(raw >= lo) || !(raw <= hi)) {
    throw InputError(std::string("custom trajectory: ") + r.name + ": " + std::to_string(value) +
                     " " + r.unit + " does not fit the register");
  }
  std::uint16_t words[mb::kHoldingCount] = {};
  mb::encode(r, static_cast<std::int64_t>(raw), words);
  for (unsigned i = 0; i < mb::width(r.type); ++i) {
    block[r.address - mb::kCustomFirst + i] = words[r.address + i];
  }
}

double get(const std::uint16_t* block, const mb::Register& r) {
  std::uint16_t words[mb::kHoldingCount] = {};
  for (unsigned i = 0; i < mb::width(r.type); ++i) {
    words[r.address + i] = block[r.address - mb::kCustomFirst + i];
  }
  return static_cast<double>(mb::decode(r, words)) * r.scale_num / r.scale_den;
}

}  // namespace

std::vector<std::uint16_t> custom_trajectory_block(const BlendedFourierTrajectory& t) {
  std::vector<std::uint16_t> block(mb::kCustomCount, 0);
  const std::size_t n = t.fourier.a_rad_s[0].size();
  if (n < 1 || n > mb::kCustomMaxHarmonics) {
    throw InputError("custom trajectory: custom_harmonics: " + std::to_string(n) +
                     " harmonics; the controller takes 1 to 6");
  }
  const double i32 = std::numeric_limits<std::int32_t>::max();
  put(block, mb::kCustomBaseFrequency, t.fourier.base_frequency_hz, 1, mb::kCustomMaxFrequency_mHz);
  const double mHz = t.fourier.base_frequency_hz * 1000.0;
  if (std::abs(mHz - std::round(mHz)) > 1e-9 * mHz) {
    throw InputError(
        "custom trajectory: custom_base_frequency: " + std::to_string(t.fourier.base_frequency_hz) +
        " Hz is not a whole number of mHz");
  }
  put(block, mb::kCustomHarmonics, static_cast<double>(n), 1, mb::kCustomMaxHarmonics);
  put(block, mb::kCustomPeriods, t.periods, 1, mb::kMaxRepetitions);
  put(block, mb::kCustomBlend, t.blend_s, 1, mb::kCustomMaxBlend_ms);
  const double w = 2.0 * std::numbers::pi * t.fourier.base_frequency_hz;
  for (unsigned j = 0; j < 3; ++j) {
    put(block, mb::custom_q0(j), t.fourier.q0_rad[j], -i32, i32);
    if (t.fourier.a_rad_s[j].size() != n || t.fourier.b_rad_s[j].size() != n) {
      throw InputError("custom trajectory: every joint needs the same harmonics");
    }
    for (unsigned k = 0; k < n; ++k) {
      // q = a/(k w) sin - b/(k w) cos = A sin + B cos.
      const double kw = (k + 1) * w;
      put(block, mb::custom_sin(j, k), t.fourier.a_rad_s[j][k] / kw, -i32, i32);
      put(block, mb::custom_cos(j, k), -t.fourier.b_rad_s[j][k] / kw, -i32, i32);
    }
  }
  return block;
}

BlendedFourierTrajectory custom_trajectory_of(const std::uint16_t* block) {
  BlendedFourierTrajectory t;
  t.fourier.base_frequency_hz = get(block, mb::kCustomBaseFrequency);
  t.periods = static_cast<unsigned>(get(block, mb::kCustomPeriods));
  t.blend_s = get(block, mb::kCustomBlend);
  const auto n = static_cast<unsigned>(
      std::min<double>(get(block, mb::kCustomHarmonics), mb::kCustomMaxHarmonics));
  const double w = 2.0 * std::numbers::pi * t.fourier.base_frequency_hz;
  for (unsigned j = 0; j < 3; ++j) {
    t.fourier.q0_rad[j] = get(block, mb::custom_q0(j));
    for (unsigned k = 0; k < n; ++k) {
      const double kw = (k + 1) * w;
      t.fourier.a_rad_s[j].push_back(get(block, mb::custom_sin(j, k)) * kw);
      t.fourier.b_rad_s[j].push_back(-get(block, mb::custom_cos(j, k)) * kw);
    }
  }
  return t;
}

}  // namespace delta
