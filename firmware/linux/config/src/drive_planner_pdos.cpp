// A drive's PDOs in its bring-up plan: the feedback TPDO1 carries, each
// PDO's COB-ID, mapping (written, or the drive's fixed one) and
// transmission type, and the TPDOs the controller does not use turned off.
#include "delta/can/protocol.hpp"
#include "drive_planner.hpp"

namespace fw_linux::planning {

namespace p = delta::can::protocol;

// A PDO's mapping as the EDS gives it by default.
PdoLayout Planner::default_layout(PdoObjects which) const {
  PdoLayout layout;
  const auto count = value({which.mapping(), 0});
  layout.count = static_cast<std::uint8_t>(count && *count <= 8 ? *count : 0);
  for (unsigned i = 0; i < layout.count; ++i) {
    const auto e = value({which.mapping(), static_cast<std::uint8_t>(i + 1)});
    layout.entries[i] = static_cast<std::uint32_t>(e.value_or(0));
  }
  return layout;
}

// Current actual value (0x6078) where the drive can send it, else torque
// actual value (0x6077); with a fixed TPDO1, what it carries.
void Planner::decide_feedback() {
  if (eds_ == nullptr) return;
  const PdoObjects tpdo1{false, 1};
  bool current = mappable(kCurrentActual);
  bool torque = mappable(kTorqueActual);
  if (has({tpdo1.mapping(), 0}) && !mapping_writable(tpdo1)) {
    const PdoLayout fixed = default_layout(tpdo1);
    current = fixed.offset_of(kCurrentActual) >= 0;
    torque = fixed.offset_of(kTorqueActual) >= 0;
  }
  plan_.feedback = current || !torque ? Feedback::kCurrent : Feedback::kTorque;
  if (!current && !torque) {
    problems_.push_back(where(kCurrentActual) +
                        ": neither 0x6078 (current actual value) nor 0x6077 (torque actual "
                        "value) can be in TPDO1: the controller could not log the drive's torque");
  }
}

// RPDO1 (controlword, target torque[, target position]), TPDO1
// (statusword, position, the feedback), TPDO2 (velocity, velocity_pdo
// only), TPDO3 (the SYNC counter, sync_counter_overflow > 0 only); the
// drive's other TPDOs off.
void Planner::pdos() {
  const od::Object feedback = plan_.feedback == Feedback::kCurrent ? kCurrentActual : kTorqueActual;
  pdo(plan_.rpdo, {true, 1},
      {{od::kControlword, 16, "controlword"},
       {kTargetTorque, 16, "target torque"},
       {kTargetPosition, 32, "target position", true}});
  pdo(plan_.sample, {false, 1},
      {{od::kStatusword, 16, "statusword"},
       {kPositionActual, 32, "position actual value"},
       {feedback, 16,
        plan_.feedback == Feedback::kCurrent ? "current actual value" : "torque actual value"}});
  if (c_.velocity_pdo) {
    pdo(plan_.velocity, {false, 2}, {{kVelocityActual, 32, "velocity actual value"}});
  } else {
    turn_off({false, 2});
  }
  if (c_.sync_counter_overflow != 0) {
    pdo(plan_.echo, {false, 3}, {{od::kSyncCounterOfSample, 8, "SYNC counter of the sample"}});
  } else if (eds_ != nullptr) {
    turn_off({false, 3});
  }
  if (eds_ != nullptr) turn_off({false, 4});
}

// A PDO the controller uses: its COB-ID, its mapping (written, or the
// drive's fixed one), its transmission type (1: every SYNC).
void Planner::pdo(PlannedPdo& planned, PdoObjects which, const std::vector<Wanted>& wanted) {
  planned.used = true;
  planned.number = which.number;
  cob_id(planned, which);
  const bool cob_writable = writable({which.communication(), 1});
  if (eds_ != nullptr && has({which.mapping(), 0}) && !mapping_writable(which)) {
    fixed_layout(planned, which, wanted);
  } else {
    for (const Wanted& w : wanted) {
      if (w.optional && !mappable(w.object)) continue;
      const bool said = w.object.index == kTargetTorque.index ||
                        w.object.index == kTorqueActual.index ||
                        w.object.index == kCurrentActual.index;
      if (!has(w.object) && said) continue;  // mode() or decide_feedback() said so
      if (!mappable(w.object)) {
        const co::EdsVariable* v = find(w.object);
        const std::string why =
            w.object.index == od::kSyncCounterOfSample.index
                ? "sync_counter_overflow = " + std::to_string(c_.sync_counter_overflow) +
                      " needs it in TPDO3 (docs/protocol.md); set sync_counter_overflow = 0 for "
                      "this drive"
                : which.name() + " must carry it";
        problem(w.object, w.name, why,
                v != nullptr && v->opaque ? opaque_text(*v) : "is not PDO-mappable");
      }
      planned.layout.entries[planned.layout.count++] =
          entry(w.object, bits(w.object, w.generic_bits));
    }
    if (!mapping_writable(which)) {
      problem({which.mapping(), 0}, which.name() + " mapping",
              "the controller writes its " + which.name() + " there");
    }
  }
  if (!which.receive && eds_ != nullptr) {
    const od::Object type{which.communication(), 2};
    const auto v = value(type);
    if (writable(type)) {
      planned.transmission_type = 1;
    } else if (!v || *v != 1) {
      problem(type, which.name() + " transmission type", "the drive would not answer every SYNC",
              v ? "is fixed at " + std::to_string(*v) : "is not writable and has no value");
    }
  }
  pdo_writes(planned, which, cob_writable);
}

// The PDO's COB-ID: the predefined one where the controller can set it,
// else the drive's own, which must be on.
void Planner::cob_id(PlannedPdo& planned, PdoObjects which) {
  const od::Object cob{which.communication(), 1};
  planned.cob_id = which.cob_id(jd_.node);
  if (writable(cob)) return;
  const auto v = value(cob);
  if (has(cob) && v && (*v & od::kPdoInvalid) == 0) {
    planned.cob_id = static_cast<std::uint32_t>(*v & 0x7FF);  // 11-bit IDs
    return;
  }
  problem(cob, which.name() + " COB-ID", "the controller cannot turn " + which.name() + " on",
          v ? "is read-only and off" : "is read-only without a value");
}

// A fixed mapping must carry what the controller needs, and an RPDO
// nothing the controller cannot fill.
void Planner::fixed_layout(PlannedPdo& planned, PdoObjects which,
                           const std::vector<Wanted>& wanted) {
  planned.layout = default_layout(which);
  planned.mapping_written = false;
  for (const Wanted& w : wanted) {
    if (w.optional || planned.layout.offset_of(w.object) >= 0) continue;
    problem({which.mapping(), 0}, which.name() + " mapping",
            std::string("it does not carry ") + object_text(w.object) + " (" + w.name + ")",
            "is read-only");
  }
  for (unsigned i = 0; i < planned.layout.count; ++i) {
    const od::Object o{static_cast<std::uint16_t>(planned.layout.entries[i] >> 16),
                       static_cast<std::uint8_t>(planned.layout.entries[i] >> 8)};
    if (o.index >= 0x0008 && !has(o)) {
      problem({which.mapping(), 0}, which.name() + " mapping",
              "it maps " + object_text(o) + ", which the file does not have", "is read-only");
    }
  }
  for (unsigned i = 0; which.receive && i < planned.layout.count; ++i) {
    const od::Object o{static_cast<std::uint16_t>(planned.layout.entries[i] >> 16),
                       static_cast<std::uint8_t>(planned.layout.entries[i] >> 8)};
    const bool known = o.index < 0x0008 || o.index == 0x6040 || o.index == 0x6071 ||
                       o.index == 0x607A || o.index == 0x6060;
    if (!known) {
      problem({which.mapping(), 0}, which.name() + " mapping",
              "it carries " + object_text(o) + ", which the controller does not send",
              "is read-only");
    }
  }
}

// CiA 301's order: the PDO off, its transmission type, no entries, the
// entries, their count, the PDO on.
void Planner::pdo_writes(const PlannedPdo& planned, PdoObjects which, bool cob_writable) {
  const od::Object cob{which.communication(), 1};
  const std::string name = which.name();
  // Bit 30 (no remote request) as the drive has it by default: drives
  // without RTR refuse a COB-ID that clears it.
  const std::uint32_t rtr = static_cast<std::uint32_t>(value(cob).value_or(0)) & kNoRtr;
  if (cob_writable) {
    write(cob, 4, planned.cob_id | rtr | od::kPdoInvalid, name + " COB-ID", "off");
  }
  const od::Object type{which.communication(), 2};
  if (!which.receive && eds_ != nullptr && writable(type)) {
    write(type, 1, planned.transmission_type, name + " transmission type", "1 (every SYNC)");
  }
  if (planned.mapping_written) {
    const std::uint16_t map = which.mapping();
    write({map, 0}, 1, 0, name + " mapping count", "0");
    for (unsigned i = 0; i < planned.layout.count; ++i) {
      write({map, static_cast<std::uint8_t>(i + 1)}, 4, planned.layout.entries[i],
            name + " mapping entry", hex(planned.layout.entries[i], 8));
    }
    write({map, 0}, 1, planned.layout.count, name + " mapping count",
          std::to_string(planned.layout.count));
  }
  if (cob_writable) {
    write(cob, 4, planned.cob_id | rtr, name + " COB-ID", hex(planned.cob_id, 3) + ", on");
  }
}

// A TPDO the controller does not use: off, where the drive lets it.
void Planner::turn_off(PdoObjects which) {
  const od::Object cob{which.communication(), 1};
  if (!writable(cob)) return;
  const std::uint32_t rtr = static_cast<std::uint32_t>(value(cob).value_or(0)) & kNoRtr;
  write(cob, 4, which.cob_id(jd_.node) | rtr | od::kPdoInvalid, which.name() + " COB-ID",
        "off (not used)");
}

}  // namespace fw_linux::planning
