// The motor drives of the default robot, written once: the emulator's drives
// are built from these values, and the firmware's Linux port assumes them
// unless its configuration says otherwise. Units at the motor unless named
// "joint".
#pragma once

#include <cstdint>

namespace delta {

struct DriveModel {
  double gear_ratio{10.0};               // motor turns per joint turn
  double rated_current_A{2.0};           // object 0x6075 (as mA)
  double rated_torque_Nm{0.2};           // object 0x6076 (as mN m), = k_t * rated current
  double gearbox_efficiency{0.9};        // joint torque = ratio * efficiency * motor torque
  std::uint32_t counts_per_rev{131072};  // 17-bit encoder, object 0x608F:1
  bool inverted{false};                  // positive motor turns move the joint negative
  double joint_zero_rad{0.0};            // the joint angle at encoder count 0

  // The motor's torque constant, k_t = rated torque / rated current [N m/A].
  double torque_constant_Nm_per_A() const { return rated_torque_Nm / rated_current_A; }
};

inline constexpr DriveModel kDefaultDrive{};

}  // namespace delta
