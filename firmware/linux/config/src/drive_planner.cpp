// A drive's settings in its bring-up plan: identity, scaling, torque mode,
// cycle period, limits and heartbeats, each read or written by SDO.
#include "drive_planner.hpp"

#include <cmath>

#include "delta/can/protocol.hpp"

namespace fw_linux::planning {

namespace p = delta::can::protocol;

std::string Planner::where(od::Object o) const {
  const co::EdsVariable* v = find(o);
  // Appended piece by piece: GCC 12's -Wrestrict takes ":" + std::to_string()
  // here for an overlapping copy (GCC bug 105329).
  std::string text = key_ + "eds (" + jd_.eds_path;
  if (v != nullptr) {
    text += ':';
    text += std::to_string(v->line);
  }
  return text + ")";
}

// The device type, and the identity the configuration expects (0x1018).
void Planner::identity() {
  if (need(od::kDeviceType, false, "device type", "CiA 301 requires it"))
    read(od::kDeviceType, SdoCheck::kDeviceType, "device type");
  if (need(od::kVendorId, false, "vendor ID", "CiA 301 requires it"))
    read(od::kVendorId, SdoCheck::kVendorId, "vendor ID");
  const DriveIdentity& id = jd_.identity;
  const struct {
    bool expected;
    od::Object object;
    SdoCheck check;
    const char* what;
  } parts[] = {
      {id.product_code.has_value(), od::kProductCode, SdoCheck::kProductCode, "product code"},
      {id.revision.has_value(), od::kRevisionNumber, SdoCheck::kRevision, "revision number"},
      {id.serial.has_value(), od::kSerialNumber, SdoCheck::kSerial, "serial number"}};
  for (const auto& part : parts) {
    if (!part.expected) continue;
    // [DeviceInfo]'s numbers are checked where the drive has the object;
    // a configured serial number must be checkable.
    if (part.check != SdoCheck::kSerial && !has(part.object)) {
      plan_.warnings.push_back(std::string("the ") + part.what +
                               " of [DeviceInfo] is not checked: " + "the drive has no " +
                               object_text(part.object));
      continue;
    }
    if (need(part.object, false, part.what, id.source + " expects one")) {
      read(part.object, part.check, part.what);
    }
  }
}

// The rated values and the encoder resolution: read from the drive where
// it has them (and checked against the configuration), else configured.
void Planner::scaling() {
  const delta::DriveModel& m = jd_.model;
  if (eds_ == nullptr) {  // the generic profile: as the drive reports them
    read(od::kMotorRatedCurrent, SdoCheck::kRatedCurrent, "motor rated current");
    read(od::kMotorRatedTorque, SdoCheck::kRatedTorque, "motor rated torque");
    read(od::kEncoderIncrements, SdoCheck::kEncoderIncrements, "encoder increments");
    return;
  }
  if (plan_.feedback == Feedback::kCurrent) {
    rated_value(od::kMotorRatedCurrent, SdoCheck::kRatedCurrent, "motor rated current",
                "rated_current_A", jd_.rated_current_set, m.rated_current_A, 1000.0);
  }
  if (jd_.torque_unit == TorqueUnit::kPerMille) {
    rated_value(od::kMotorRatedTorque, SdoCheck::kRatedTorque, "motor rated torque",
                "rated_torque_Nm", jd_.rated_torque_set, m.rated_torque_Nm, 1000.0);
  }
  torque_unit_hint();
  if (readable(od::kEncoderIncrements)) {
    const auto v = value(od::kEncoderIncrements);
    if (jd_.counts_per_rev_set && v && *v != 0 && *v != m.counts_per_rev) {
      problems_.push_back(where(od::kEncoderIncrements) + ": 0x608F:01 (position encoder " +
                          "resolution) is " + std::to_string(*v) + " in the EDS, but " + key_ +
                          "counts_per_rev = " + std::to_string(m.counts_per_rev) +
                          ": which is the encoder's? (docs/drives.md)");
    }
    if (!jd_.counts_per_rev_set && (!v || *v == 0)) {
      problems_.push_back(key_ + "counts_per_rev is not set, and " + where(od::kEncoderIncrements) +
                          " gives 0x608F:01 (position encoder resolution) no value: set it to "
                          "the counts per motor revolution of 0x6064 (docs/drives.md)");
    }
    read(od::kEncoderIncrements, SdoCheck::kEncoderIncrements, "encoder increments");
  } else if (!jd_.counts_per_rev_set) {
    problems_.push_back(where(od::kEncoderIncrements) +
                        ": no object 0x608F:01 (position encoder resolution), and " + key_ +
                        "counts_per_rev is not set: set it to the counts per motor revolution "
                        "of 0x6064 (docs/drives.md)");
  }
}

// CiA 402's torque is per mille of 0x6076 (motor rated torque). A drive
// that takes a target torque (0x6071) but has no 0x6076 most often takes
// it in a unit of its own (Trinamic's TMCM drives: mA), which per mille
// would scale by a factor of ten or more: said where the configuration
// keeps per mille without saying so.
void Planner::torque_unit_hint() {
  if (jd_.torque_unit_set || !has(kTargetTorque) || has(od::kMotorRatedTorque)) return;
  plan_.warnings.push_back(where(kTargetTorque) +
                           " has 0x6071 (target torque) but no 0x6076 (motor rated torque), "
                           "which CiA 402's per mille needs: such a drive most often takes torque "
                           "in a unit of its own (mA on Trinamic TMCM drives); check its manual "
                           "and set " +
                           key_ +
                           "torque_unit (mA, mNm, or per_mille where the manual says so; "
                           "docs/drives.md)");
}

// A rated value (0x6075 mA, 0x6076 mN m): the configuration's, or the
// EDS's default; the drive's is read where it has the object.
void Planner::rated_value(od::Object o, SdoCheck check, const std::string& name,
                          const std::string& key, bool set, double configured, double to_drive) {
  const auto configured_units = static_cast<std::uint32_t>(std::llround(configured * to_drive));
  const auto v = value(o);
  const bool eds_gives = v.has_value() && *v != 0;
  if (set && eds_gives && *v != configured_units) {
    problems_.push_back(where(o) + ": " + object_text(o) + " (" + name + ") is " +
                        std::to_string(*v) + " in the EDS, but " + key_ + key + " = " +
                        std::to_string(configured) + " (" + std::to_string(configured_units) +
                        "): which is the motor's?");
  }
  if (!set && !eds_gives) {
    const std::string what = object_text(o) + " (" + name + ")";
    problems_.push_back(key_ + key + " is not set, and " + where(o) +
                        (find(o) == nullptr ? " has no object " + what
                         : v                ? " gives " + what + " a default of 0"
                                            : " gives " + what + " no default") +
                        ": set it from the motor's data sheet, as the drive is configured "
                        "(docs/drives.md)");
  }
  if (readable(o)) {
    read(o, check, name);
  } else {
    (check == SdoCheck::kRatedCurrent ? plan_.rated_current_mA : plan_.rated_torque_mNm) =
        configured_units;
  }
}

// Cyclic synchronous torque where 0x6502 offers it (or gives no value:
// then 0x6061 confirms it), else profile torque with a warning.
void Planner::mode() {
  need(od::kModesOfOperation, true, "modes of operation",
       "the controller cannot select a torque mode");
  if (!has(kTargetTorque)) {
    problem(kTargetTorque, "target torque", "the drive cannot take a torque command");
  }
  const auto modes = readable(kSupportedModes) ? value(kSupportedModes) : std::nullopt;
  bool confirm = false;
  if (eds_ == nullptr) {
    plan_.mode_reason = "the generic profile (docs/drives.md)";
  } else if (!modes) {
    plan_.mode_reason = "0x6502 (supported drive modes) gives no value: 0x6061 confirms it";
    confirm = true;
  } else if (*modes & kSupportsCst) {
    plan_.mode_reason = "0x6502 = " + hex(static_cast<std::uint32_t>(*modes), 8) + " offers it";
  } else if (*modes & kSupportsProfileTorque) {
    plan_.mode = delta::can::cia402::kModeProfileTorque;
    plan_.mode_reason = "0x6502 = " + hex(static_cast<std::uint32_t>(*modes), 8) +
                        " offers profile torque, not cyclic synchronous torque";
    plan_.warnings.push_back(
        "profile torque (mode 4) is not synchronous: the drive applies each target torque when "
        "the RPDO arrives, not at the SYNC, so the torque lags by up to a cycle");
  } else {
    problem(kSupportedModes, "supported drive modes",
            "neither cyclic synchronous torque (bit 9) nor profile torque (bit 3): the drive "
            "has no torque mode",
            "is " + hex(static_cast<std::uint32_t>(*modes), 8));
  }
  const bool cst = plan_.mode == delta::can::cia402::kModeCyclicSynchronousTorque;
  write(od::kModesOfOperation, 1, static_cast<std::uint8_t>(plan_.mode), "modes of operation",
        std::to_string(plan_.mode) + (cst ? ", cyclic synchronous torque" : ", profile torque"));
  if (confirm) {
    if (readable(od::kModesOfOperationDisplay)) {
      read(od::kModesOfOperationDisplay, SdoCheck::kModeDisplay, "modes of operation display");
    } else {
      plan_.warnings.push_back("neither 0x6502 nor 0x6061 tells whether the drive took mode 10");
    }
  }
  if (!cst && writable(kTorqueSlope)) {
    // The full rated torque within one cycle: the slope does not shape
    // the controller's torque.
    const std::uint32_t slope = 1000u * (1000000u / c_.period_us);
    write(kTorqueSlope, 4, slope, "torque slope", std::to_string(slope) + " per mille/s");
  }
}

// The cycle period where the drive takes one: 0x1006, else 0x60C2
// (value and power of ten of seconds), else a warning.
void Planner::cycle() {
  const std::string period = std::to_string(c_.period_us) + " us";
  if (c_.sync_counter_overflow != 0) {
    // CiA 301: 0x1019 is written while 0x1006 is 0.
    const std::string why = "sync_counter_overflow = " + std::to_string(c_.sync_counter_overflow) +
                            " needs it; set sync_counter_overflow = 0 for this drive";
    if (need(od::kCommunicationCycle, true, "communication cycle period", why) &&
        need(od::kSyncCounterOverflow, true, "synchronous counter overflow value", why)) {
      write(od::kCommunicationCycle, 4, 0, "communication cycle period (0 first)", "0 us");
      write(od::kSyncCounterOverflow, 1, c_.sync_counter_overflow,
            "synchronous counter overflow value", std::to_string(c_.sync_counter_overflow));
    }
  }
  if (writable(od::kCommunicationCycle)) {
    plan_.cycle = "0x1006 = " + period;
    write(od::kCommunicationCycle, 4, c_.period_us, "communication cycle period", period);
    return;
  }
  if (writable(kInterpolationPeriodValue) && has(kInterpolationPeriodIndex)) {
    // The unit: 10^index s; -3 (ms) or -4 (0.1 ms) where the value fits a byte.
    const auto fixed = value(kInterpolationPeriodIndex);
    const bool free = writable(kInterpolationPeriodIndex);
    for (int index = -3; index >= -6; --index) {
      const std::uint32_t unit_us = index == -3 ? 1000 : index == -4 ? 100 : index == -5 ? 10 : 1;
      const bool usable = free || (fixed && static_cast<std::int8_t>(*fixed) == index);
      if (!usable || c_.period_us % unit_us != 0 || c_.period_us / unit_us > 255) continue;
      plan_.cycle = "0x60C2 = " + std::to_string(c_.period_us / unit_us) + " x 10^" +
                    std::to_string(index) + " s";
      if (free) {
        write(kInterpolationPeriodIndex, 1, static_cast<std::uint8_t>(index),
              "interpolation time index",
              std::to_string(index) + " (10^" + std::to_string(index) + " s)");
      }
      write(kInterpolationPeriodValue, 1, c_.period_us / unit_us, "interpolation time period",
            std::to_string(c_.period_us / unit_us) + " (" + period + ")");
      return;
    }
    problem(kInterpolationPeriodValue, "interpolation time period",
            "period_us = " + std::to_string(c_.period_us) + " is not a byte in its unit",
            "cannot be set to " + period);
    return;
  }
  plan_.cycle = "not told (the drive has neither 0x1006 nor 0x60C2)";
  plan_.warnings.push_back(
      "the drive is not told the cycle period: it has neither a writable "
      "0x1006 nor 0x60C2");
}

// The drive's own torque limit (0x6072) at the controller's, in per mille.
void Planner::limits() {
  if (eds_ == nullptr) return;  // the generic profile limits the current (0x6073) itself
  if (!writable(kMaxTorque)) {
    const auto v = value(kMaxTorque);
    if (has(kMaxTorque) && v && *v == 0) {
      problem(kMaxTorque, "max torque", "the drive would give no torque", "is read-only and 0");
    } else if (!has(kMaxTorque)) {
      plan_.warnings.push_back("no 0x6072 (max torque): the drive's own torque limit is not set");
    }
    return;
  }
  if (jd_.torque_unit != TorqueUnit::kPerMille && !jd_.rated_torque_set) {
    // 0x6072 is per mille of the rated torque, which is not known here.
    const auto v = value(kMaxTorque);
    if (v && *v == 0) {
      problem(kMaxTorque, "max torque",
              "the drive would give no torque; set " + key_ +
                  "rated_torque_Nm so that the controller can write it in per mille",
              "defaults to 0");
    } else {
      plan_.warnings.push_back(
          "0x6072 (max torque) is left as the drive has it: it is per mille "
          "of a rated torque the configuration does not give");
    }
    return;
  }
  const delta::DriveModel& m = jd_.model;
  const double motor_Nm = c_.max_torque_Nm / (m.gear_ratio * m.gearbox_efficiency);
  const double per_mille = std::ceil(motor_Nm / m.rated_torque_Nm * 1000.0);
  const auto limit = static_cast<std::uint32_t>(std::min(std::max(per_mille, 1.0), 32767.0));
  if (per_mille > 32767.0) {
    plan_.warnings.push_back(
        "gains.max_torque_Nm = " + std::to_string(c_.max_torque_Nm) + " N m is " +
        std::to_string(static_cast<long long>(per_mille)) + " per mille of " + key_ +
        "rated_torque_Nm at the motor, more than 0x6072 (max torque) holds: the drive's own "
        "limit is capped at 32767 per mille (" +
        std::to_string(32.767 * m.rated_torque_Nm * m.gear_ratio * m.gearbox_efficiency) +
        " N m at the joint); check both values");
  }
  write(kMaxTorque, 2, limit, "max torque",
        std::to_string(limit) + " per mille (gains.max_torque_Nm at the motor)");
}

// The drive's heartbeat (the controller supervises it) and its consumer
// of the controller's (the drive stops by itself when the controller is gone).
void Planner::heartbeats() {
  if (need(od::kProducerHeartbeat, true, "producer heartbeat time",
           "the controller supervises the drive by its heartbeat")) {
    write(od::kProducerHeartbeat, 2, c_.heartbeat_ms, "producer heartbeat time",
          std::to_string(c_.heartbeat_ms) + " ms");
  }
  if (!writable(od::kConsumerHeartbeat)) {
    plan_.warnings.push_back(
        "no writable 0x1016:01 (consumer heartbeat time): the drive will not "
        "stop by itself when the controller is gone");
    return;
  }
  write(od::kConsumerHeartbeat, 4,
        od::consumer_heartbeat(p::kControllerNode, c_.controller_heartbeat_timeout_ms),
        "consumer heartbeat time",
        "node " + std::to_string(p::kControllerNode) + ", " +
            std::to_string(c_.controller_heartbeat_timeout_ms) + " ms");
}

}  // namespace fw_linux::planning
