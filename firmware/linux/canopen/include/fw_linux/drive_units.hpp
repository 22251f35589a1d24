// Conversions between a CiA 402 drive's units and the core's Q formats, in
// integer arithmetic (the cyclic path has no floating point):
//   position: encoder counts at the motor       <-> Q3.28 rad at the joint
//   velocity: counts/s at the motor             <-> Q10.21 rad/s at the joint
//   current:  per mille of the rated current    <-> Q12.19 A
//   torque:   per mille of the rated torque     <-> Q12.19 A of motor current
//             (or mA, or mN m: jointN.torque_unit)
// The factors are fixed once from the configuration and the values the
// drive reports by SDO (rated current and torque).
#pragma once

#include <cstdint>

#include "delta/drive_model.hpp"
#include "delta/fixed/q.hpp"
#include "fw_linux/config.hpp"

namespace fw_linux {

using delta::fx::Q10_21;
using delta::fx::Q12_19;
using delta::fx::Q3_28;

class DriveUnits {
 public:
  DriveUnits() = default;
  // rated_current_mA and rated_torque_mNm as the drive reports them.
  DriveUnits(const delta::DriveModel& model, std::uint32_t rated_current_mA,
             std::uint32_t rated_torque_mNm, TorqueUnit torque_unit = TorqueUnit::kPerMille);

  Q3_28 joint_angle(std::int32_t counts) const;
  Q10_21 joint_velocity(std::int64_t counts_per_s) const;
  // The current actual value (0x6078), per mille of the rated current.
  Q12_19 current(std::int16_t per_mille) const;
  // The motor current of a torque actual value (0x6077) in the torque unit.
  Q12_19 current_from_torque(std::int16_t torque) const;
  // The target torque (object 0x6071) for a motor current in the torque
  // unit, saturated to i16.
  std::int16_t target_torque(Q12_19 current_A) const;
  // The encoder count of a joint angle (the inverse of joint_angle).
  std::int32_t counts(Q3_28 joint_angle) const;

 private:
  std::int64_t rad_per_count_q60_{0};  // joint radians per count, times 2^60, signed
  std::int64_t zero_q28_{0};           // joint angle at count 0, Q3.28 raw
  std::int64_t counts_per_joint_rev_{1};
  bool inverted_{false};
  std::uint32_t rated_current_mA_{1};
  std::uint32_t rated_torque_mNm_{1};
  std::int64_t torque_constant_uNm_per_A_{0};  // k_t, micro-N m per A
  TorqueUnit torque_unit_{TorqueUnit::kPerMille};
};

}  // namespace fw_linux
