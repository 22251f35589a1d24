// The values a commissioned drive holds, given to the emulator as the
// controller has them (delta_drive_emu --set jointN.KEY=VALUE, --config
// FILE: the controller's own configuration, docs/drives.md): rated torque
// and current, encoder resolution, gear, mounting and torque unit, each in
// the controller's range; and the run's approach_s and stop_s, the span of
// the `arm tracking` line. An EDS
// (--eds) gives a drive's defaults; these are what the user set on it, so
// they win.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "delta/drive_model.hpp"

namespace emu {

struct DriveSettings {
  std::optional<double> rated_torque_Nm;
  std::optional<double> rated_current_A;
  std::optional<std::uint32_t> counts_per_rev;
  std::optional<double> gear_ratio;
  std::optional<double> gearbox_efficiency;
  std::optional<bool> inverted;
  std::optional<double> zero_rad;
};

struct CommissionedDrives {
  std::array<DriveSettings, 3> joints;
  std::optional<std::string> torque_unit;  // per_mille, mA or mNm: one for all three
  // The controller's approach_s and stop_s: the arm tracking line's span.
  std::optional<double> approach_s;
  std::optional<double> stop_s;
  // The controller's robot = FILE: the robot the emulator moves (--robot).
  std::optional<std::string> robot;
  std::vector<std::string> taken;  // KEY=VALUE of each value set, in order

  // One `jointN.KEY=VALUE` (or `jointN.KEY = VALUE`); `where` names it in
  // errors (std::invalid_argument: the key, the value and what is taken).
  // A key of the controller's that no drive holds is false (ignored).
  bool set(const std::string& assignment, const std::string& where);
  // Every drive key of a controller configuration file (`key = value`
  // lines, `#` comments); the controller's other keys are left to it.
  void read_config(const std::string& path);
  // The drive model with these values in place of `model`'s.
  delta::DriveModel applied(unsigned joint, delta::DriveModel model) const;

 private:
  // One joint's NAME = VALUE (`what` names it in errors); false: not a
  // drive's value.
  bool set_joint(DriveSettings& d, const std::string& name, const std::string& value,
                 const std::string& what);
};

}  // namespace emu
