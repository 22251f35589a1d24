#include "fw_linux/drive_plan.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>

#include "delta/can/protocol.hpp"
#include "delta/canopen/eds.hpp"

namespace fw_linux {

namespace od = delta::can::od;
namespace co = delta::canopen;
namespace p = delta::can::protocol;

unsigned PdoLayout::bytes() const {
  unsigned bits = 0;
  for (unsigned i = 0; i < count; ++i) bits += entries[i] & 0xFF;
  return bits / 8;
}

int PdoLayout::offset_of(od::Object object) const {
  unsigned bits = 0;
  const std::uint32_t key = std::uint32_t{object.index} << 16 | std::uint32_t{object.subindex} << 8;
  for (unsigned i = 0; i < count; ++i) {
    if ((entries[i] & 0xFFFFFF00u) == key) return static_cast<int>(bits / 8);
    bits += entries[i] & 0xFF;
  }
  return -1;
}

namespace {

std::string hex(std::uint32_t v, int digits) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%0*X", digits, v);
  return b;
}

std::uint32_t entry(od::Object o, unsigned bits) {
  return std::uint32_t{o.index} << 16 | std::uint32_t{o.subindex} << 8 | bits;
}

constexpr od::Object kTargetTorque{0x6071, 0};
constexpr od::Object kTargetPosition{0x607A, 0};
constexpr od::Object kPositionActual{0x6064, 0};
constexpr od::Object kVelocityActual{0x606C, 0};
constexpr od::Object kTorqueActual{0x6077, 0};
constexpr od::Object kCurrentActual{0x6078, 0};
constexpr od::Object kMaxTorque{0x6072, 0};
constexpr od::Object kTorqueSlope{0x6087, 0};
constexpr od::Object kSupportedModes{0x6502, 0};
constexpr od::Object kInterpolationPeriodValue{0x60C2, 1};
constexpr od::Object kInterpolationPeriodIndex{0x60C2, 2};
// 0x6502's bits (CiA 402): profile torque, cyclic synchronous torque.
constexpr std::uint32_t kSupportsProfileTorque = 1u << 3;
constexpr std::uint32_t kSupportsCst = 1u << 9;
// A PDO COB-ID's bit 30: no remote transmission request (CiA 301).
constexpr std::uint32_t kNoRtr = 1u << 30;

// One PDO's objects: its communication (0x1400/0x1800 + n - 1) and
// mapping (0x1600/0x1A00 + n - 1) indices.
struct PdoObjects {
  bool receive;
  unsigned number;
  std::uint16_t communication() const {
    return static_cast<std::uint16_t>((receive ? 0x1400 : 0x1800) + number - 1);
  }
  std::uint16_t mapping() const {
    return static_cast<std::uint16_t>((receive ? 0x1600 : 0x1A00) + number - 1);
  }
  std::uint32_t cob_id(std::uint8_t node) const {
    return (receive ? 0x200u : 0x180u) + 0x100u * (number - 1) + node;
  }
  std::string name() const { return (receive ? "RPDO" : "TPDO") + std::to_string(number); }
};

// An object a PDO carries: its size in the generic profile, whether the
// controller can do without it.
struct Wanted {
  od::Object object;
  unsigned generic_bits;
  const char* name;
  bool optional{false};
};

// The planning of one drive; `eds` null for the generic profile.
class Planner {
 public:
  Planner(const PortConfig& c, unsigned joint, DrivePlan& plan, std::vector<std::string>& problems)
      : c_(c), jd_(c.joints[joint]), eds_(jd_.eds.get()), plan_(plan), problems_(problems) {
    plan_.joint = joint;
    plan_.node = jd_.node;
    plan_.eds_path = jd_.eds_path;
    plan_.torque_unit = jd_.torque_unit;
    key_ = "joint" + std::to_string(joint + 1) + ".";
  }

  void run() {
    if (eds_ != nullptr && eds_->node_id && *eds_->node_id != jd_.node) {
      problems_.push_back(key_ + "eds (" + jd_.eds_path + ") is a DCF commissioned for node " +
                          std::to_string(*eds_->node_id) + ", but " + key_ +
                          "node = " + std::to_string(jd_.node) + ": which node is the drive?");
    }
    decide_feedback();
    identity();
    scaling();
    mode();
    cycle();
    limits();
    heartbeats();
    pdos();
  }

 private:
  // --- what the EDS says ---
  const co::EdsVariable* find(od::Object o) const {
    return eds_ == nullptr ? nullptr : eds_->find(o.index, o.subindex);
  }
  // Without an EDS the generic profile has every object the bring-up uses.
  bool has(od::Object o) const { return eds_ == nullptr || find(o) != nullptr; }
  bool readable(od::Object o) const {
    const co::EdsVariable* v = find(o);
    return eds_ == nullptr || (v != nullptr && !v->opaque && co::readable(v->access));
  }
  bool writable(od::Object o) const {
    const co::EdsVariable* v = find(o);
    return eds_ == nullptr || (v != nullptr && !v->opaque && co::writable(v->access));
  }
  bool mappable(od::Object o) const {
    const co::EdsVariable* v = find(o);
    return eds_ == nullptr || (v != nullptr && !v->opaque && v->pdo_mappable);
  }
  std::optional<std::uint64_t> value(od::Object o) const {
    const co::EdsVariable* v = find(o);
    if (v == nullptr || v->opaque) return std::nullopt;
    return v->value(jd_.node);
  }
  unsigned bits(od::Object o, unsigned generic) const {
    const co::EdsVariable* v = find(o);
    return v == nullptr ? generic : v->size_bytes() * 8;
  }
  // "joint2.eds (epos2.eds:1234)", the line where the EDS has the object.
  std::string where(od::Object o) const {
    const co::EdsVariable* v = find(o);
    return key_ + "eds (" + jd_.eds_path + (v ? ":" + std::to_string(v->line) : "") + ")";
  }
  // A problem with an object: missing, or as `state` says.
  void problem(od::Object o, const std::string& name, const std::string& why,
               const std::string& state = "") {
    const std::string what = object_text(o) + " (" + name + ")";
    problems_.push_back(where(o) + ": " +
                        (find(o) == nullptr ? "no object " + what : what + " " + state) + ": " +
                        why);
  }
  static std::string opaque_text(const co::EdsVariable& v) {
    return "is of data type " + hex(v.declared_type, 4) + ", which this file does not define";
  }
  // The object must be there and readable (writable): else a problem.
  bool need(od::Object o, bool write, const std::string& name, const std::string& why) {
    if (write ? writable(o) : readable(o)) return true;
    const co::EdsVariable* v = find(o);
    problem(o, name, why,
            v != nullptr && v->opaque ? opaque_text(*v)
            : write                   ? "is not writable"
                                      : "is not readable");
    return false;
  }

  // --- the plan's transfers ---
  void read(od::Object o, SdoCheck check, const std::string& what) {
    plan_.actions.push_back({o, 0, 0, check, what, ""});
  }
  void write(od::Object o, std::uint8_t size, std::uint32_t v, const std::string& what,
             const std::string& shown) {
    plan_.actions.push_back({o, size, v, SdoCheck::kNone, what, shown});
  }

  bool mapping_writable(PdoObjects which) const {
    return writable({which.mapping(), 0}) && writable({which.mapping(), 1});
  }
  PdoLayout default_layout(PdoObjects which) const;
  void decide_feedback();
  void identity();
  void scaling();
  void rated_value(od::Object o, SdoCheck check, const std::string& name, const std::string& key,
                   bool set, double configured, double to_drive);
  void mode();
  void cycle();
  void limits();
  void heartbeats();
  void pdos();
  void pdo(PlannedPdo& planned, PdoObjects which, const std::vector<Wanted>& wanted);
  void cob_id(PlannedPdo& planned, PdoObjects which);
  void fixed_layout(PlannedPdo& planned, PdoObjects which, const std::vector<Wanted>& wanted);
  void pdo_writes(const PlannedPdo& planned, PdoObjects which, bool cob_writable);
  void turn_off(PdoObjects which);

  const PortConfig& c_;
  const JointDrive& jd_;
  const co::Eds* eds_;
  DrivePlan& plan_;
  std::vector<std::string>& problems_;
  std::string key_;
};

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
  if (readable(od::kEncoderIncrements)) {
    const auto v = value(od::kEncoderIncrements);
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
    plan_.mode_reason = "the generic profile (docs/protocol.md)";
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

}  // namespace

namespace {

std::string layout_text(const PlannedPdo& pdo) {
  std::string text;
  for (unsigned i = 0; i < pdo.layout.count; ++i) {
    const std::uint32_t e = pdo.layout.entries[i];
    text += (i ? ", " : "") +
            object_text({static_cast<std::uint16_t>(e >> 16), static_cast<std::uint8_t>(e >> 8)}) +
            " (" + std::to_string(e & 0xFF) + " bits)";
  }
  return text + (pdo.mapping_written ? "; mapping written" : "; the drive's fixed mapping");
}

std::string rated_text(std::uint32_t fixed, const char* object, const char* unit) {
  return fixed != 0
             ? std::to_string(fixed) + " " + unit + " (configured; the drive has no " + object + ")"
             : std::string("read from ") + object;
}

}  // namespace

std::string describe_plan(const DrivePlan& plan) {
  std::ostringstream out;
  out << "joint" << plan.joint + 1 << ": node " << int{plan.node} << ", "
      << (plan.eds_path.empty() ? "the generic CiA 402 profile (no jointN.eds)" : plan.eds_path)
      << "\n";
  const bool cst = plan.mode == delta::can::cia402::kModeCyclicSynchronousTorque;
  out << "  mode:     " << int{plan.mode}
      << (cst ? " (cyclic synchronous torque): " : " (profile torque): ") << plan.mode_reason
      << "\n";
  const char* unit = plan.torque_unit == TorqueUnit::kMilliamp           ? "mA"
                     : plan.torque_unit == TorqueUnit::kMilliNewtonMetre ? "mN m"
                                                                         : "per mille";
  if (plan.feedback == Feedback::kCurrent) {
    out << "  feedback: 0x6078 current actual value, per mille of the rated current, "
        << rated_text(plan.rated_current_mA, "0x6075", "mA") << "\n";
  } else {
    out << "  feedback: 0x6077 torque actual value, " << unit << "\n";
  }
  out << "  torque:   0x6071 target torque, " << unit;
  if (plan.torque_unit == TorqueUnit::kPerMille) {
    out << " of the rated torque, " << rated_text(plan.rated_torque_mNm, "0x6076", "mN m");
  }
  out << "\n  cycle:    " << plan.cycle << "\n";
  const std::pair<const PlannedPdo*, const char*> pdos[] = {
      {&plan.rpdo, "RPDO"}, {&plan.sample, "TPDO"}, {&plan.velocity, "TPDO"}, {&plan.echo, "TPDO"}};
  for (const auto& [pdo, kind] : pdos) {
    if (!pdo->used) continue;
    out << "  " << kind << pdo->number << ":    COB-ID " << hex(pdo->cob_id, 3);
    if (std::string(kind) == "TPDO") out << ", transmission type " << int{pdo->transmission_type};
    out << ": " << layout_text(*pdo) << "\n";
  }
  out << "  SDO transfers (" << plan.actions.size() << "):\n";
  for (const SdoAction& a : plan.actions) {
    out << "    " << (a.size == 0 ? "read  " : "write ") << object_text(a.object) << "  " << a.what;
    if (a.size != 0) out << " = " << a.shown;
    out << "\n";
  }
  for (const std::string& w : plan.warnings) out << "  warning: " << w << "\n";
  return out.str();
}

std::string object_text(od::Object o) {
  return hex(o.index, 4) + ":" + hex(o.subindex, 2).substr(2);
}

DrivePlans plan_drives(const PortConfig& c) {
  DrivePlans plans;
  for (unsigned j = 0; j < 3; ++j) Planner(c, j, plans.drives[j], plans.problems).run();
  return plans;
}

}  // namespace fw_linux
