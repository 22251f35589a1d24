#include "fw_linux/drive_units.hpp"

#include <cmath>
#include <numbers>

#include "delta/fixed/q.hpp"

namespace fw_linux {
namespace {

__extension__ typedef __int128 int128;

std::int64_t round_shift(int128 v, int shift) {
  const int128 half = int128{1} << (shift - 1);
  return static_cast<std::int64_t>(v >= 0 ? (v + half) >> shift : -((-v + half) >> shift));
}

std::int32_t saturate32(std::int64_t v) {
  if (v > INT32_MAX) return INT32_MAX;
  if (v < INT32_MIN) return INT32_MIN;
  return static_cast<std::int32_t>(v);
}

// a * b / c rounded to nearest, c > 0.
std::int64_t mul_div_round(std::int64_t a, std::int64_t b, std::int64_t c) {
  const int128 p = int128{a} * b;
  return static_cast<std::int64_t>(p >= 0 ? (p + c / 2) / c : -((-p + c / 2) / c));
}

}  // namespace

// The configuration-time factors are computed in double once; the cyclic
// conversions below are integer only.
DriveUnits::DriveUnits(const delta::DriveModel& model, std::uint32_t rated_current_mA,
                       std::uint32_t rated_torque_mNm, TorqueUnit torque_unit)
    : rad_per_count_q60_(std::llround(
          std::ldexp(2.0 * std::numbers::pi / (model.counts_per_rev * model.gear_ratio), 60))),
      zero_q28_(std::llround(std::ldexp(model.joint_zero_rad, 28))),
      counts_per_joint_rev_(std::llround(model.counts_per_rev * model.gear_ratio)),
      inverted_(model.inverted),
      rated_current_mA_(rated_current_mA == 0 ? 1 : rated_current_mA),
      rated_torque_mNm_(rated_torque_mNm == 0 ? 1 : rated_torque_mNm),
      torque_constant_uNm_per_A_(std::llround(model.torque_constant_Nm_per_A() * 1e6)),
      torque_unit_(torque_unit) {}

Q3_28 DriveUnits::joint_angle(std::int32_t counts) const {
  const std::int64_t c = inverted_ ? -std::int64_t{counts} : counts;
  return Q3_28::from_raw(saturate32(round_shift(int128{c} * rad_per_count_q60_, 32) + zero_q28_));
}

Q10_21 DriveUnits::joint_velocity(std::int64_t counts_per_s) const {
  const std::int64_t c = inverted_ ? -counts_per_s : counts_per_s;
  return Q10_21::from_raw(saturate32(round_shift(int128{c} * rad_per_count_q60_, 39)));
}

Q12_19 DriveUnits::current(std::int16_t per_mille) const {
  // i = per_mille / 1000 * rated_mA / 1000 A, in units of 2^-19 A.
  return Q12_19::from_raw(
      saturate32(mul_div_round(std::int64_t{per_mille} * rated_current_mA_, 1 << 19, 1000000)));
}

Q12_19 DriveUnits::current_from_torque(std::int16_t torque) const {
  if (torque_unit_ == TorqueUnit::kMilliamp) {
    return Q12_19::from_raw(saturate32(mul_div_round(torque, 1 << 19, 1000)));
  }
  if (torque_constant_uNm_per_A_ == 0) return Q12_19{};  // not brought up yet
  // motor torque [uN m]: per mille of the rated torque [mN m], or mN m.
  const std::int64_t torque_uNm = torque_unit_ == TorqueUnit::kPerMille
                                      ? std::int64_t{torque} * rated_torque_mNm_
                                      : std::int64_t{torque} * 1000;
  return Q12_19::from_raw(
      saturate32(mul_div_round(torque_uNm, 1 << 19, torque_constant_uNm_per_A_)));
}

std::int16_t DriveUnits::target_torque(Q12_19 current_A) const {
  std::int64_t v = 0;
  if (torque_unit_ == TorqueUnit::kMilliamp) {
    v = mul_div_round(current_A.raw(), 1000, 1 << 19);
  } else {
    // motor torque [uN m] = k_t * i; per mille = torque / rated torque * 1000.
    const std::int64_t torque_uNm =
        mul_div_round(std::int64_t{current_A.raw()}, torque_constant_uNm_per_A_, 1 << 19);
    v = torque_unit_ == TorqueUnit::kPerMille ? mul_div_round(torque_uNm, 1, rated_torque_mNm_)
                                              : mul_div_round(torque_uNm, 1, 1000);
  }
  if (v > INT16_MAX) return INT16_MAX;
  if (v < INT16_MIN) return INT16_MIN;
  return static_cast<std::int16_t>(v);
}

std::int32_t DriveUnits::counts(Q3_28 joint_angle) const {
  // counts = (q - zero) / (2 pi) * counts_per_joint_rev; 2 pi in Q3.28 is exact enough
  // for a reference value (tests, emulator start).
  const std::int64_t rel = std::int64_t{joint_angle.raw()} - zero_q28_;
  const std::int64_t two_pi_q28 = 1686629713;  // round(2 pi 2^28)
  const std::int64_t c = mul_div_round(rel, counts_per_joint_rev_, two_pi_q28);
  return saturate32(inverted_ ? -c : c);
}

}  // namespace fw_linux
