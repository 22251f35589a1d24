// A drive's PDOs in its bring-up plan: the feedback TPDO1 carries, each
// PDO's COB-ID, mapping (written, or the drive's fixed one) and
// transmission type, and the TPDOs the controller does not use turned off.
#include <algorithm>
#include <array>

#include "delta/can/protocol.hpp"
#include "drive_planner.hpp"

namespace fw_linux::planning {

namespace p = delta::can::protocol;

// Whether the controller fills a mapping entry of an RPDO: dummy entries
// (0x0001-0x0007), the controlword, target torque and position, the mode.
bool controller_fills(std::uint32_t entry) {
  const auto index = static_cast<std::uint16_t>(entry >> 16);
  return index < 0x0008 || index == 0x6040 || index == 0x6071 || index == 0x607A || index == 0x6060;
}

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

// Whether the controller has a use of its own for TPDO n: TPDO2 the
// velocity, TPDO3 the SYNC counter, TPDO4 the arm-side encoder.
bool Planner::own_use(unsigned n) const {
  return (n == 2 && c_.velocity_pdo) || (n == 3 && c_.sync_counter_overflow != 0) ||
         (n == 4 && c_.arm_encoders);
}

// Whether the PDO can carry `wanted` (the optional ones aside): its fixed
// mapping has each (and, an RPDO, nothing the controller cannot fill), or
// the controller can map each.
bool Planner::carries(PdoObjects which, const std::vector<Wanted>& wanted) const {
  if (eds_ == nullptr) return true;
  if (!has({which.mapping(), 0})) return false;
  const bool is_fixed = fixed(which);
  const PdoLayout layout = is_fixed ? default_layout(which) : PdoLayout{};
  for (const Wanted& w : wanted) {
    if (w.optional) continue;
    if (is_fixed ? layout.offset_of(w.object) < 0 : !mappable(w.object)) return false;
  }
  for (unsigned i = 0; is_fixed && which.receive && i < layout.count; ++i) {
    if (!controller_fills(layout.entries[i])) return false;
  }
  return true;
}

// The first PDO with a fixed mapping that carries `wanted` (CiA 301's
// whole range: 0x1600-0x17FF, 0x1A00-0x1BFF), `skip` and the TPDOs the
// controller has other uses for aside.
std::optional<unsigned> Planner::fixed_pdo(bool receive, const std::vector<Wanted>& wanted,
                                           unsigned skip) const {
  if (eds_ == nullptr) return std::nullopt;
  for (unsigned n = 1; n <= 512; ++n) {
    const bool taken = !receive && own_use(n);
    if (n == skip || taken) continue;
    if (fixed({receive, n}) && carries({receive, n}, wanted)) return n;
  }
  return std::nullopt;
}

// Whether a TPDO can carry `o`: TPDO1 as the controller maps it, or a
// fixed TPDO that has it.
bool Planner::carried(od::Object o) const {
  if (!fixed({false, 1}) && mappable(o)) return true;
  return fixed_pdo(false, {{o, 16, ""}}).has_value();
}

// Current actual value (0x6078) where a TPDO can carry it, else torque
// actual value (0x6077).
void Planner::decide_feedback() {
  if (eds_ == nullptr) return;
  const bool current = carried(kCurrentActual);
  const bool torque = carried(kTorqueActual);
  plan_.feedback = current || !torque ? Feedback::kCurrent : Feedback::kTorque;
  if (!current && !torque) {
    problems_.push_back(where(kCurrentActual) +
                        ": neither 0x6078 (current actual value) nor 0x6077 (torque actual "
                        "value) can be in a TPDO: the controller could not log the drive's torque");
  }
}

// A predefined PDO (1 to 4) whose COB-ID a PDO above them may take: one
// the drive does not have, or one the controller can turn off (and does).
std::optional<unsigned> Planner::free_id(bool receive, const std::vector<unsigned>& used) {
  for (const unsigned k : receive ? std::array{1u, 2u, 3u, 4u} : std::array{4u, 3u, 2u, 1u}) {
    const bool taken =
        std::find(used.begin(), used.end(), k) != used.end() || (!receive && own_use(k));
    if (taken) continue;
    const PdoObjects pdo{receive, k};
    if (!has({pdo.communication(), 1})) return k;
    if (writable({pdo.communication(), 1})) {
      turn_off(pdo);
      return k;
    }
  }
  return std::nullopt;
}

// Where a PDO above PDO4 has its COB-ID: one of PDO1 to PDO4's where the
// controller sets it (`used` those it has other uses for).
PdoObjects Planner::numbered(bool receive, unsigned n, std::vector<unsigned>& used) {
  PdoObjects which{receive, n};
  if (n <= 4 || !writable({which.communication(), 1})) return which;
  if (const auto k = free_id(receive, used)) {
    which.id_of = *k;
    used.push_back(*k);
    return which;
  }
  const std::string kind = receive ? "RPDO" : "TPDO";
  problem({which.communication(), 1}, which.name() + " COB-ID",
          "CiA 301 predefines the COB-IDs of " + kind + "1 to " + kind +
              "4 only, and none of those can give it theirs (each is in use or has a read-only "
              "COB-ID)",
          "is writable");
  return which;
}

// RPDO1, or where it cannot carry the control a fixed RPDO that does.
PdoObjects Planner::control_pdo(const std::vector<Wanted>& control) {
  const PdoObjects rpdo1{true, 1};
  if (carries(rpdo1, control)) return rpdo1;
  const auto n = fixed_pdo(true, control, 1);
  if (!n) return rpdo1;  // its problems say why
  std::vector<unsigned> used{*n};
  const PdoObjects which = numbered(true, *n, used);  // off, if it takes RPDO1's COB-ID
  if (which.id_of != 1) turn_off(rpdo1);
  return which;
}

// Where TPDO1 cannot carry the sample: a fixed TPDO with the feedback,
// and what it lacks in a TPDO the controller maps (TPDO1, else TPDO4) or
// in another fixed one. False where there is none: TPDO1's problems then
// say why.
bool Planner::split_sample(const std::vector<Wanted>& sample) {
  const auto first = fixed_pdo(false, {sample.back()});
  if (!first) return false;
  const PdoLayout layout = default_layout({false, *first});
  std::vector<Wanted> own;
  std::vector<Wanted> rest;
  for (const Wanted& w : sample) (layout.offset_of(w.object) >= 0 ? own : rest).push_back(w);
  std::optional<unsigned> second;
  for (const unsigned k : {1u, 4u}) {
    if (!rest.empty() && !second && k != *first && !fixed({false, k}) && carries({false, k}, rest))
      second = k;
  }
  if (!rest.empty() && !second) second = fixed_pdo(false, rest, *first);
  if (!rest.empty() && !second) return false;
  std::vector<unsigned> used{*first};
  if (second) used.push_back(*second);
  pdo(plan_.sample, numbered(false, *first, used), own);
  if (second) pdo(plan_.sample_rest, numbered(false, *second, used), rest);
  tpdos_taken_ = used;
  if (!taken(1)) turn_off({false, 1});
  return true;
}

// RPDO1 (controlword, target torque[, target position]) or a fixed RPDO
// that carries them; TPDO1 (statusword, position, the feedback) or a fixed
// TPDO with the feedback and a second TPDO with the rest; TPDO2
// (velocity, velocity_pdo only), TPDO3 (the SYNC counter,
// sync_counter_overflow > 0 only), TPDO4 (the arm-side encoder,
// arm_encoders only); the drive's other TPDOs off.
void Planner::pdos() {
  const od::Object feedback = plan_.feedback == Feedback::kCurrent ? kCurrentActual : kTorqueActual;
  const std::vector<Wanted> control{{od::kControlword, 16, "controlword"},
                                    {kTargetTorque, 16, "target torque"},
                                    {kTargetPosition, 32, "target position", true}};
  pdo(plan_.rpdo, control_pdo(control), control);
  const std::vector<Wanted> sample{
      {od::kStatusword, 16, "statusword"},
      {kPositionActual, 32, "position actual value"},
      {feedback, 16,
       plan_.feedback == Feedback::kCurrent ? "current actual value" : "torque actual value"}};
  if (carries({false, 1}, sample) || !split_sample(sample)) pdo(plan_.sample, {false, 1}, sample);
  if (c_.velocity_pdo) {
    pdo(plan_.velocity, {false, 2}, {{kVelocityActual, 32, "velocity actual value"}});
  } else if (!taken(2)) {
    turn_off({false, 2});
  }
  if (c_.sync_counter_overflow != 0) {
    pdo(plan_.echo, {false, 3}, {{od::kSyncCounterOfSample, 8, "SYNC counter of the sample"}});
    echo_last();
  } else if (eds_ != nullptr && !taken(3)) {
    turn_off({false, 3});
  }
  if (c_.arm_encoders) {
    arm_pdo();
  } else if (eds_ != nullptr && !taken(4)) {
    turn_off({false, 4});
  }
}

// TPDO4: the arm-side encoder (0x60E4:1), arm_encoders only. It comes
// after TPDO3 on the bus, so the SYNC counter's echo could not end the
// cycle's TPDOs.
void Planner::arm_pdo() {
  if (c_.sync_counter_overflow != 0) {
    problems_.push_back(key_ + "arm_encoders = true puts the arm-side encoder in TPDO4 (" +
                        hex(PdoObjects{false, 4}.cob_id(jd_.node), 3) +
                        "), after the SYNC counter's echo in TPDO3: set sync_counter_overflow "
                        "= 0 or arm_encoders = false");
    return;
  }
  if (taken(4)) {
    problems_.push_back(key_ + "eds (" + jd_.eds_path +
                        "): TPDO4 carries part of the sample on this drive, so it cannot "
                        "carry the arm-side encoder: set arm_encoders = false");
    return;
  }
  pdo(plan_.arm, {false, 4}, {{kArmPositionActual, 32, "additional position actual value"}});
}

// The SYNC counter's echo (TPDO3) tells the master that a cycle's sample
// is in: the sample must come first on the bus, in one TPDO with a lower
// COB-ID (CAN arbitration sends the lowest first).
void Planner::echo_last() {
  const std::uint32_t sample = plan_.sample.cob_id & 0x7FF;
  if (!plan_.sample_rest.used && sample < plan_.echo.cob_id) return;
  problems_.push_back(
      key_ + "eds (" + jd_.eds_path + "): sync_counter_overflow = " +
      std::to_string(c_.sync_counter_overflow) + " needs the sample in one TPDO before TPDO3's " +
      hex(plan_.echo.cob_id, 3) + " on the bus, and this drive's comes in " +
      PdoObjects{false, plan_.sample.number}.name() + " (" + hex(sample, 3) + ")" +
      (plan_.sample_rest.used ? " and " + PdoObjects{false, plan_.sample_rest.number}.name() : "") +
      ": set sync_counter_overflow = 0");
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
    if (!controller_fills(planned.layout.entries[i])) {
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
  // CiA 301 moves a COB-ID only while the PDO is off: a PDO above PDO4
  // that is on by default goes off at its own first.
  const auto own = value(cob);
  if (cob_writable && which.id_of != 0 && own && (*own & od::kPdoInvalid) == 0) {
    write(cob, 4, static_cast<std::uint32_t>(*own) | od::kPdoInvalid, name + " COB-ID",
          "off (at its own COB-ID)");
  }
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
