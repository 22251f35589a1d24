#include "fw_linux/canopen_master.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "delta/can/emcy.hpp"
#include "delta/can/protocol.hpp"
#include "fw/torque_from_current.hpp"

namespace fw_linux {

namespace p = delta::can::protocol;
namespace od = delta::can::od;
namespace sdo = delta::can::sdo;
using delta::can::Frame;
using delta::can::cia402::State;

namespace {

std::string hex(std::uint32_t v, int digits) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%0*X", digits, v);
  return b;
}

Frame frame(std::uint32_t id, std::uint8_t dlc, const std::array<std::uint8_t, 8>& data) {
  Frame f;
  f.id = id;
  f.dlc = dlc;
  f.data = data;
  return f;
}

// A mapped object's bytes in a PDO, little endian, sign-extended when
// `is_signed`; 0 when the layout does not carry it.
std::int64_t pdo_field(const std::array<std::uint8_t, 8>& data, const PdoLayout& layout,
                       od::Object o, unsigned bytes, bool is_signed) {
  const int at = layout.offset_of(o);
  if (at < 0 || static_cast<unsigned>(at) + bytes > 8) return 0;
  std::uint64_t v = 0;
  for (unsigned i = 0; i < bytes; ++i)
    v |= std::uint64_t{data[static_cast<unsigned>(at) + i]} << (8 * i);
  if (is_signed && bytes < 8 && (v >> (8 * bytes - 1)) != 0) v |= ~std::uint64_t{0} << (8 * bytes);
  return static_cast<std::int64_t>(v);
}

// Every entry of an RPDO's layout from `fill` (object -> value); what the
// controller does not know (dummy entries) is 0.
template <class Fill>
void pack_pdo(std::array<std::uint8_t, 8>& data, const PdoLayout& layout, Fill fill) {
  unsigned at = 0;
  for (unsigned i = 0; i < layout.count; ++i) {
    const std::uint32_t e = layout.entries[i];
    const auto v = static_cast<std::uint64_t>(
        fill(od::Object{static_cast<std::uint16_t>(e >> 16), static_cast<std::uint8_t>(e >> 8)}));
    const unsigned bytes = (e & 0xFF) / 8;
    for (unsigned b = 0; b < bytes && at + b < 8; ++b) {
      data[at + b] = static_cast<std::uint8_t>(v >> (8 * b));
    }
    at += bytes;
  }
}

}  // namespace

CanopenMaster::CanopenMaster(const PortConfig& config, FrameSink& bus)
    : config_(config), plans_(plan_drives(config)), core_(controller_config(config)), bus_(bus) {
  if (!plans_.problems.empty()) throw ConfigError(plans_.problems.front());
  // In lock-step a slow machine must not look like a silent drive: an SDO
  // answer is awaited at least as long as a PDO answer.
  const std::uint32_t sdo_ms = config.mode == CycleMode::kLockStep
                                   ? std::max(config.sdo_timeout_ms, config.lockstep_timeout_ms)
                                   : config.sdo_timeout_ms;
  sdo_timeout_us_ = std::uint64_t{sdo_ms} * 1000;
  for (unsigned j = 0; j < 3; ++j) {
    drives_[j].node = config.joints[j].node;
    drives_[j].plan = &plans_.drives[j];
    drives_[j].sdo = sdo::Client(static_cast<std::uint32_t>(sdo_timeout_us_));
  }
  const std::uint64_t timeout_us = std::uint64_t{config.heartbeat_timeout_ms} * 1000;
  heartbeat_timeout_cycles_ = (timeout_us + config.period_us - 1) / config.period_us;
}

CanopenMaster::Drive* CanopenMaster::drive_for(std::uint8_t node) {
  for (Drive& d : drives_) {
    if (d.node == node) return &d;
  }
  return nullptr;
}

void CanopenMaster::fail(const std::string& why) {
  if (phase_ == Phase::kFailed) return;  // the first problem is the one to tell
  phase_ = Phase::kFailed;
  bring_up_problem_ = why;
  cyclic_problem_.kind = CyclicProblem::Kind::kNone;
}

void CanopenMaster::restart() {
  for (Drive& d : drives_) {
    const std::uint8_t node = d.node;
    const DrivePlan* plan = d.plan;
    d = Drive{};
    d.node = node;
    d.plan = plan;
    d.sdo = sdo::Client(static_cast<std::uint32_t>(sdo_timeout_us_));
  }
  phase_ = Phase::kIdle;
  failure_reported_ = false;
  bus_error_ = false;
  clear_problem();
}

void CanopenMaster::send_sdo(Drive& d, std::uint64_t now_us) {
  const SdoAction& a = d.plan->actions[d.sdo_step];
  if (a.size == 0) {
    d.sdo.upload(a.object.index, a.object.subindex, d.sdo_bytes, sdo::Transfer::kAuto, now_us);
  } else {
    for (unsigned i = 0; i < 4; ++i) d.sdo_bytes[i] = static_cast<std::uint8_t>(a.value >> (8 * i));
    d.sdo.download(a.object.index, a.object.subindex, std::span(d.sdo_bytes).first(a.size),
                   sdo::Transfer::kAuto, now_us);
  }
  ++d.sdo_attempts;
  pump_sdo(d);
}

// The client's frames onto the bus; a full transmit queue keeps the rest
// for the next call (the transfer waits, it does not fail).
void CanopenMaster::pump_sdo(Drive& d) {
  sdo::Payload payload;
  while (d.sdo.pending(payload)) {
    if (!bus_.send(frame(p::cob_id(p::kSdoRx, d.node), 8, payload))) return;
    d.sdo.sent(now_us_);
  }
}

fw::DriveConfigProgress CanopenMaster::configure_drives() {
  if (phase_ == Phase::kStarting) {
    // Done when every drive answered and none is in fault any more.
    for (const Drive& d : drives_) {
      if (!d.got_tpdo1 || d.state == State::kFault || d.state == State::kFaultReactionActive) {
        record({.kind = d.got_tpdo1 ? CyclicProblem::Kind::kStaysInFault
                                    : CyclicProblem::Kind::kSilentAfterStart,
                .node = d.node});
        return fw::DriveConfigProgress::kInProgress;
      }
    }
    phase_ = Phase::kCyclic;
    clear_problem();
    return fw::DriveConfigProgress::kDone;
  }
  // A failure found while frames came in (an abort, a wrong value) is
  // reported here once; a call after that is the core starting again.
  if (phase_ == Phase::kFailed && !failure_reported_) {
    failure_reported_ = true;
    return fw::DriveConfigProgress::kFailed;
  }
  if (phase_ == Phase::kCyclic || phase_ == Phase::kFailed) restart();  // the core restarted
  if (phase_ == Phase::kIdle) {
    // Every drive to pre-operational (PDOs off), then the SDO bring-up.
    leave_network();
    phase_ = Phase::kConfiguring;
    for (Drive& d : drives_) send_sdo(d, now_us_);
    return fw::DriveConfigProgress::kInProgress;
  }
  bool all_done = true;
  for (Drive& d : drives_) {
    if (phase_ == Phase::kFailed) break;
    if (bring_up_done(d)) continue;
    all_done = false;
    d.sdo.tick(now_us_);
    pump_sdo(d);
    if (d.sdo.status() == sdo::ClientStatus::kBusy) continue;
    if (d.sdo.status() == sdo::ClientStatus::kAborted && d.sdo_attempts > config_.sdo_retries) {
      const od::Object o = d.plan->actions[d.sdo_step].object;
      fail("node " + std::to_string(d.node) + ": no answer to the SDO request for " +
           object_text(o) + " within " + std::to_string(sdo_timeout_us_ / 1000) + " ms (" +
           std::to_string(d.sdo_attempts) + " attempts); is the drive powered and on the bus?");
      break;
    }
    send_sdo(d, now_us_);  // the first request, or again after a timeout
  }
  if (phase_ == Phase::kFailed) {
    failure_reported_ = true;
    return fw::DriveConfigProgress::kFailed;
  }
  if (!all_done) return fw::DriveConfigProgress::kInProgress;
  // Every drive configured: start the network; the cyclic exchange begins.
  std::array<std::uint8_t, 8> nmt{};
  p::pack(nmt, p::kNmtCommand, p::kNmtStart);
  p::pack(nmt, p::kNmtNode, 0);
  bus_.send(frame(p::cob_id(p::kNmt, 0), 2, nmt));
  phase_ = Phase::kStarting;
  for (Drive& d : drives_) d.last_heartbeat_cycle = cycle_;
  return fw::DriveConfigProgress::kInProgress;
}

void CanopenMaster::leave_network() {
  std::array<std::uint8_t, 8> nmt{};
  p::pack(nmt, p::kNmtCommand, p::kNmtEnterPreOperational);
  p::pack(nmt, p::kNmtNode, 0);
  bus_.send(frame(p::cob_id(p::kNmt, 0), 2, nmt));
}

// "node 1, 0x6060:00 (modes of operation): ", the bring-up step's words
// for its problems: built only for a problem (every step of every drive's
// bring-up gets an answer).
std::string CanopenMaster::step_text(const Drive& d) const {
  return "node " + std::to_string(d.node) + ", " + object_text(d.plan->actions[d.sdo_step].object) +
         ": ";
}

// "joint1.", the configuration's keys of the drive's joint.
std::string CanopenMaster::joint_key(const Drive& d) const {
  return "joint" + std::to_string(&d - drives_.data() + 1) + ".";
}

void CanopenMaster::handle_sdo_response(Drive& d, const Frame& f) {
  if (d.sdo.status() != sdo::ClientStatus::kBusy) return;  // a duplicate or stray answer
  if (f.dlc != 8) {
    return fail(step_text(d) + "SDO response with " + std::to_string(f.dlc) + " bytes");
  }
  d.sdo.on_frame(f.data, now_us_);
  pump_sdo(d);
  if (d.sdo.status() == sdo::ClientStatus::kBusy) return;
  if (d.sdo.status() == sdo::ClientStatus::kAborted) {
    const std::uint32_t code = d.sdo.abort_code();
    if (d.sdo.aborted_by_server()) {
      return fail(step_text(d) + "the drive aborted the transfer: " + hex(code, 8) + " (" +
                  sdo::abort_meaning(code) + ")");
    }
    return fail(step_text(d) + "unexpected SDO response, command byte " + hex(f.data[0], 2) + " (" +
                sdo::abort_meaning(code) + ")");
  }
  std::uint32_t value = 0;
  for (unsigned i = 0; i < d.sdo.uploaded_size() && i < 4; ++i) {
    value |= std::uint32_t{d.sdo_bytes[i]} << (8 * i);
  }
  take_step_result(d, value);
}

// A bring-up step's answer: what was read is checked and kept; then the
// next step, or the drive's units once it was the last.
void CanopenMaster::take_step_result(Drive& d, std::uint32_t value) {
  if (!checked(d, value)) return;
  d.sdo_attempts = 0;
  ++d.sdo_step;
  if (!bring_up_done(d)) return send_sdo(d, now_us_);
  const DrivePlan& plan = *d.plan;
  if (plan.rated_current_mA != 0) d.rated_current_mA = plan.rated_current_mA;
  if (plan.rated_torque_mNm != 0) d.rated_torque_mNm = plan.rated_torque_mNm;
  d.units = DriveUnits(joint(d).model, d.rated_current_mA, d.rated_torque_mNm, plan.torque_unit);
}

// A rated value the drive reports (0x6075 mA, 0x6076 mN m): kept; it must
// not be 0, and must be the configured one where the configuration sets it.
bool CanopenMaster::rated_value(Drive& d, std::uint32_t value, std::uint32_t& kept, bool set,
                                double configured, const char* key) {
  const SdoAction& a = d.plan->actions[d.sdo_step];
  const char* unit = a.check == SdoCheck::kRatedCurrent ? "mA" : "mN m";
  const auto expected = static_cast<std::uint32_t>(std::llround(configured * 1000.0));
  if (value == 0) {
    fail(step_text(d) + "the drive reports a " + a.what + " of 0 " + unit +
         ": set it in the drive");
    return false;
  }
  if (set && value != expected) {
    fail(step_text(d) + "the drive's " + a.what + " is " + std::to_string(value) + " " + unit +
         "; " + joint_key(d) + key + " says " + std::to_string(expected) + " " + unit +
         ": which is the motor's?");
    return false;
  }
  kept = value;
  return true;
}

// What a read says, against the plan and the configuration.
bool CanopenMaster::checked(Drive& d, std::uint32_t value) {
  const SdoAction& a = d.plan->actions[d.sdo_step];
  const JointDrive& jd = joint(d);
  switch (a.check) {
    case SdoCheck::kNone:
      return true;
    case SdoCheck::kDeviceType:
      if ((value & 0xFFFF) == (od::kDeviceTypeServo & 0xFFFF)) return true;
      fail(step_text(d) + "device type " + hex(value, 8) + " is not a CiA 402 drive (0x....0192)");
      return false;
    case SdoCheck::kVendorId:
    case SdoCheck::kProductCode:
    case SdoCheck::kRevision:
    case SdoCheck::kSerial:
      return identity_matches(d, value);
    case SdoCheck::kRatedCurrent:
      return rated_value(d, value, d.rated_current_mA, jd.rated_current_set,
                         jd.model.rated_current_A, "rated_current_A");
    case SdoCheck::kRatedTorque:
      return rated_value(d, value, d.rated_torque_mNm, jd.rated_torque_set,
                         jd.model.rated_torque_Nm, "rated_torque_Nm");
    case SdoCheck::kEncoderIncrements:
      if (value == jd.model.counts_per_rev) return true;
      fail(step_text(d) + "the encoder has " + std::to_string(value) +
           " counts per revolution; the configuration says " +
           std::to_string(jd.model.counts_per_rev) + " (" + joint_key(d) + "counts_per_rev)");
      return false;
    case SdoCheck::kModeDisplay:
      if (static_cast<std::int8_t>(value & 0xFF) == d.plan->mode) return true;
      fail(step_text(d) + "the drive shows mode " +
           std::to_string(static_cast<std::int8_t>(value & 0xFF)) + " after mode " +
           std::to_string(d.plan->mode) +
           " was written to 0x6060: it does not take it (docs/drives.md)");
      return false;
  }
  return true;
}

// 0x1018 against the configuration: the vendor ID, product code and serial
// number exactly, the revision by its major part (CiA 301: the minor part
// changes without changing the CANopen behaviour).
bool CanopenMaster::identity_matches(Drive& d, std::uint32_t found) {
  const DriveIdentity& id = joint(d).identity;
  const SdoAction& a = d.plan->actions[d.sdo_step];
  const std::optional<std::uint32_t> expected[] = {id.vendor_id, id.product_code, id.revision,
                                                   id.serial};
  const std::optional<std::uint32_t>& want =
      expected[static_cast<unsigned>(a.check) - static_cast<unsigned>(SdoCheck::kVendorId)];
  if (!want) return true;
  const bool revision = a.check == SdoCheck::kRevision;
  const bool same = revision ? (found >> 16) == (*want >> 16) : found == *want;
  if (same) return true;
  fail(step_text(d) + a.what + " " + hex(found, 8) + "; " + id.source + " expects " +
       hex(*want, 8) + (revision ? " (major revision " + std::to_string(*want >> 16) + ")" : "") +
       ": is this the drive the configuration describes?");
  return false;
}

// A TPDO in the cycle's window: the sample and the velocity are held;
// without a SYNC counter they count at once, with one when the echo
// confirms the cycle. Fields are where the plan's layout maps them.
void CanopenMaster::handle_tpdo(Drive& d, const Frame& f, const PlannedPdo& pdo) {
  const DrivePlan& plan = *d.plan;
  const auto expected = static_cast<std::uint8_t>(pdo.layout.bytes());
  const auto number = static_cast<std::uint8_t>(pdo.number);
  if (f.dlc != expected) {
    d.malformed = true;
    if (&pdo == &plan.sample || &pdo == &plan.sample_rest)
      d.got_tpdo1 = true;  // answered, if badly
    if (&pdo == &plan.velocity) d.got_tpdo2 = true;
    if (&pdo == &plan.arm) d.got_tpdo4 = true;
    record({.kind = CyclicProblem::Kind::kMalformedPdo,
            .node = d.node,
            .pdo = number,
            .can_id = f.id,
            .dlc = f.dlc,
            .expected_dlc = expected});
    return;
  }
  if (!window_open_) {
    d.late = true;
    ++late_frames_;
    record({.kind = CyclicProblem::Kind::kLatePdo, .node = d.node, .pdo = number, .can_id = f.id});
    return;
  }
  if (&pdo == &plan.echo) return take_sync_echo(d, f);
  if (&pdo == &plan.velocity) {
    d.held.velocity_counts_s =
        static_cast<std::int32_t>(pdo_field(f.data, pdo.layout, {0x606C, 0}, 4, true));
    d.held.tpdo2 = true;
  } else if (&pdo == &plan.arm) {
    d.held.arm_counts =
        static_cast<std::int32_t>(pdo_field(f.data, pdo.layout, {0x60E4, 1}, 4, true));
    d.held.tpdo4 = true;
  } else {
    hold_sample(d, f, pdo);
  }
  if (!counted()) take_held(d);
}

// The sample's fields the PDO carries (all, or with a split sample its
// part): the sample is whole once each of its PDOs came this cycle.
void CanopenMaster::hold_sample(Drive& d, const Frame& f, const PlannedPdo& pdo) {
  const DrivePlan& plan = *d.plan;
  const od::Object feedback =
      plan.feedback == Feedback::kCurrent ? od::Object{0x6078, 0} : od::Object{0x6077, 0};
  if (pdo.layout.offset_of(od::kStatusword) >= 0) {
    d.held.statusword =
        static_cast<std::uint16_t>(pdo_field(f.data, pdo.layout, od::kStatusword, 2, false));
  }
  if (pdo.layout.offset_of({0x6064, 0}) >= 0) {
    d.held.position_counts =
        static_cast<std::int32_t>(pdo_field(f.data, pdo.layout, {0x6064, 0}, 4, true));
  }
  if (pdo.layout.offset_of(feedback) >= 0) {
    d.held.current_per_mille =
        static_cast<std::int16_t>(pdo_field(f.data, pdo.layout, feedback, 2, true));
  }
  d.held.parts |= &pdo == &plan.sample ? 1u : 2u;
  d.held.tpdo1 = d.held.parts == (plan.sample_rest.used ? 3u : 1u);
}

// TPDO3: the counter of the SYNC the drive's held TPDOs answer. Another
// SYNC's counter means they are an earlier cycle's, late: dropped.
void CanopenMaster::take_sync_echo(Drive& d, const Frame& f) {
  const auto counter = static_cast<std::uint8_t>(
      pdo_field(f.data, d.plan->echo.layout, od::kSyncCounterOfSample, 1, false));
  if (counter == sync_counter_) return take_held(d);
  d.held = {};
  d.late = true;
  ++late_frames_;
  record({.kind = CyclicProblem::Kind::kStalePdo,
          .node = d.node,
          .pdo = 3,
          .can_id = f.id,
          .counter = counter,
          .sync_counter = sync_counter_});
}

void CanopenMaster::take_held(Drive& d) const {
  if (d.held.tpdo1) {
    d.statusword = d.held.statusword;
    d.state = delta::can::cia402::decode_statusword(d.statusword);
    d.position_counts = d.held.position_counts;
    d.current_per_mille = d.held.current_per_mille;
    d.got_tpdo1 = true;
  }
  if (d.held.tpdo2) {
    d.velocity_counts_s = d.held.velocity_counts_s;
    d.got_tpdo2 = true;
  }
  if (d.held.tpdo4) {
    d.arm_counts = d.held.arm_counts;
    d.got_tpdo4 = true;
  }
  // A split sample's first part waits for the other within the cycle
  // (begin_cycle drops it); with a SYNC counter the echo ends the cycle's.
  const Drive::Sample part = d.held;
  d.held = {};
  if (!counted() && !part.tpdo1)
    d.held = {.statusword = part.statusword,
              .position_counts = part.position_counts,
              .current_per_mille = part.current_per_mille,
              .parts = part.parts};
}

void CanopenMaster::on_frame(const delta::can::Received& r, std::uint64_t now_us) {
  now_us_ = now_us;
  if (r.error) {
    if (r.error->bus_off || r.error->error_passive) {
      bus_error_ = true;
      record({.kind = CyclicProblem::Kind::kBusError,
              .bus_off = r.error->bus_off,
              .error_class = r.error->raw_class});
    }
    return;
  }
  const Frame& f = r.frame;
  if (f.extended || f.remote) return;
  const std::uint8_t node = p::node_id(f.id);
  const std::uint32_t function = p::function_code(f.id);
  Drive* d = drive_for(node);
  if (d == nullptr) return;
  const DrivePlan& plan = *d->plan;
  if (function == p::kSdoTx.base_id) {
    handle_sdo_response(*d, f);
  } else if (f.id == plan.sample.cob_id) {
    if (cyclic()) handle_tpdo(*d, f, plan.sample);
  } else if (plan.sample_rest.used && f.id == plan.sample_rest.cob_id) {
    if (cyclic()) handle_tpdo(*d, f, plan.sample_rest);
  } else if (plan.velocity.used && f.id == plan.velocity.cob_id) {
    if (cyclic()) handle_tpdo(*d, f, plan.velocity);
  } else if (plan.arm.used && f.id == plan.arm.cob_id) {
    if (cyclic()) handle_tpdo(*d, f, plan.arm);
  } else if (plan.echo.used && f.id == plan.echo.cob_id) {
    if (cyclic() && counted()) handle_tpdo(*d, f, plan.echo);
  } else if (function == p::kEmcy.base_id) {
    const auto code = static_cast<std::uint16_t>(p::unpack(f.data, p::kEmcyErrorCode));
    if (code != od::kEmcyErrorReset) {
      d->emergency = true;
      record({.kind = CyclicProblem::Kind::kEmergency, .node = node, .emcy_code = code});
    }
  } else if (function == p::kHeartbeat.base_id) {
    d->heartbeat_seen = true;
    d->last_heartbeat_cycle = cycle_;
    if (f.dlc >= 1 && f.data[0] == p::kNmtStateBootUp && phase_ == Phase::kCyclic) {
      d->rebooted = true;
      record({.kind = CyclicProblem::Kind::kRebooted, .node = node});
    }
  }
}

void CanopenMaster::begin_cycle(std::uint64_t now_us) {
  now_us_ = now_us;
  ++cycle_;
  for (Drive& d : drives_) {
    d.got_tpdo1 = d.got_tpdo2 = d.got_tpdo4 = false;
    d.held = {};
  }
  window_open_ = cyclic();
  if (!window_open_) return;
  ++syncs_sent_;
  if (!counted()) {
    bus_.send(frame(p::cob_id(p::kSync, 0), 0, {}));
    return;
  }
  // CiA 301: 1, 2, ... up to the overflow value, then 1 again.
  sync_counter_ = static_cast<std::uint8_t>(sync_counter_ % config_.sync_counter_overflow + 1);
  std::array<std::uint8_t, 8> data{};
  p::pack(data, p::kSyncCounter, sync_counter_);
  bus_.send(frame(p::cob_id(p::kSync, 0), 1, data));
}

bool CanopenMaster::exchange_complete() const {
  if (phase_ == Phase::kConfiguring) {
    for (const Drive& d : drives_) {
      if (d.sdo.status() == sdo::ClientStatus::kBusy) return false;
    }
    return true;
  }
  if (!window_open_) return true;
  for (const Drive& d : drives_) {
    if (!d.got_tpdo1 || (config_.velocity_pdo && !d.got_tpdo2) ||
        (config_.arm_encoders && !d.got_tpdo4))
      return false;
  }
  return true;
}

void CanopenMaster::end_window() {
  window_open_ = false;
}

std::uint64_t CanopenMaster::sdo_deadline_us() const {
  std::uint64_t earliest = 0;
  for (const Drive& d : drives_) {
    const std::uint64_t t = d.sdo.deadline_us();
    if (t != 0 && (earliest == 0 || t < earliest)) earliest = t;
  }
  return earliest;
}

void CanopenMaster::read_feedback(std::array<fw::DriveFeedback, 3>& out) {
  for (unsigned j = 0; j < 3; ++j) {
    Drive& d = drives_[j];
    fw::DriveFeedback& fb = out[j];
    const bool heartbeat_ok = cycle_ - d.last_heartbeat_cycle <= heartbeat_timeout_cycles_;
    if (!heartbeat_ok && phase_ == Phase::kCyclic) {
      record({.kind = CyclicProblem::Kind::kHeartbeatLost,
              .node = d.node,
              .cycle = cycle_ - d.last_heartbeat_cycle});
    } else if (!d.got_tpdo1 && phase_ == Phase::kCyclic && !d.late) {
      record({.kind = CyclicProblem::Kind::kNoTpdo1, .node = d.node, .cycle = cycle_});
    }
    const bool sample = d.got_tpdo1 && !d.malformed;
    // Read twice in one cycle, the same sample is not a new one: the
    // velocity stands (its time span would be 0).
    const bool new_sample = sample && !(d.previous_cycle != 0 && d.previous_cycle == cycle_);
    if (new_sample) {
      if (!config_.velocity_pdo) {
        // Over the cycles since the last good sample (more than one when
        // samples were missed); 0 before the first.
        const std::int64_t delta_counts =
            d.previous_cycle != 0 ? std::int64_t{d.position_counts} - d.previous_counts : 0;
        const auto span_us = static_cast<std::int64_t>(
            (d.previous_cycle != 0 ? cycle_ - d.previous_cycle : 1) * config_.period_us);
        d.velocity_counts_s = static_cast<std::int32_t>(delta_counts * 1000000 / span_us);
      }
      d.previous_counts = d.position_counts;
      d.previous_cycle = cycle_;
    }
    fb.position_rad = d.units.joint_angle(d.position_counts);
    fb.velocity_rad_s = d.units.joint_velocity(d.velocity_counts_s);
    fb.current_A = d.plan->feedback == Feedback::kCurrent
                       ? d.units.current(d.current_per_mille)
                       : d.units.current_from_torque(d.current_per_mille);
    fb.arm_position_rad = d.units.joint_angle(d.arm_counts);
    fb.fresh = sample && (!config_.velocity_pdo || d.got_tpdo2) &&
               (!config_.arm_encoders || d.got_tpdo4) && heartbeat_ok;
    fb.fault = d.emergency || d.rebooted || d.state == State::kFault ||
               d.state == State::kFaultReactionActive;
    fb.problem = d.malformed             ? fw::FeedbackProblem::kMalformed
                 : bus_error_            ? fw::FeedbackProblem::kBusError
                 : (d.late && !fb.fresh) ? fw::FeedbackProblem::kLate
                                         : fw::FeedbackProblem::kNone;
    d.malformed = false;
    d.late = false;
  }
  bus_error_ = false;
}

// "TPDO1 0x181", or both of a split sample's PDOs.
std::string CanopenMaster::sample_text(std::uint8_t node) const {
  for (const Drive& d : drives_) {
    if (d.node != node || d.plan == nullptr) continue;
    const auto text = [](const PlannedPdo& pdo) {
      return "TPDO" + std::to_string(pdo.number) + " " + hex(pdo.cob_id, 3);
    };
    return text(d.plan->sample) +
           (d.plan->sample_rest.used ? " and " + text(d.plan->sample_rest) : "");
  }
  return "TPDO1";
}

std::string CanopenMaster::last_problem() const {
  using Kind = CyclicProblem::Kind;
  const CyclicProblem& p = cyclic_problem_;
  const std::string node = "node " + std::to_string(p.node);
  const std::string pdo = "TPDO" + std::to_string(p.pdo) + " " + hex(p.can_id, 3);
  switch (p.kind) {
    case Kind::kNone:
      return bring_up_problem_;
    case Kind::kMalformedPdo:
      return node + ": " + pdo + " has " + std::to_string(p.dlc) + " bytes, expected " +
             std::to_string(p.expected_dlc);
    case Kind::kLatePdo:
      return node + ": " + pdo + " arrived after the cycle's deadline";
    case Kind::kStalePdo:
      return node + ": " + pdo + " carries SYNC counter " + std::to_string(p.counter) +
             ", this cycle's SYNC " + std::to_string(p.sync_counter) +
             ": its TPDOs answer an earlier SYNC (they arrived after their cycle's deadline)";
    case Kind::kBusError:
      return std::string("CAN bus error: ") + (p.bus_off ? "bus-off" : "error passive") +
             " (error frame class " + hex(p.error_class, 8) + ")";
    case Kind::kEmergency:
      return node + ": emergency " + hex(p.emcy_code, 4) + " (" + od::emcy_meaning(p.emcy_code) +
             ")";
    case Kind::kRebooted:
      return node + " restarted (boot-up message)";
    case Kind::kHeartbeatLost:
      return node + ": no heartbeat for " + std::to_string(p.cycle * config_.period_us / 1000) +
             " ms (timeout " + std::to_string(config_.heartbeat_timeout_ms) + " ms)";
    case Kind::kNoTpdo1:
      return node + ": no sample (" + sample_text(p.node) + ") answered the SYNC of cycle " +
             std::to_string(p.cycle);
    case Kind::kSilentAfterStart:
      return node + " sends no sample (" + sample_text(p.node) + ") after the NMT start";
    case Kind::kStaysInFault:
      return node + " stays in fault after a fault reset";
  }
  return bring_up_problem_;
}

void CanopenMaster::command_torque(const std::array<Q12_19, 3>& joint_torque_Nm) {
  for (unsigned j = 0; j < 3; ++j) {
    drives_[j].command_current_A = fw::current_from_torque(core_.torque[j], joint_torque_Nm[j]);
  }
}

void CanopenMaster::command_reference(const fw::JointAnglesQ& arm_reference_rad) {
  for (unsigned j = 0; j < 3; ++j) {
    drives_[j].reference_counts = drives_[j].units.counts(arm_reference_rad[j]);
    drives_[j].has_reference = true;
  }
}

void CanopenMaster::send_commands() {
  if (!cyclic()) return;
  for (Drive& d : drives_) {
    // While starting, only a fault-reset edge for a drive in fault.
    const bool clear_fault = phase_ == Phase::kStarting && d.state == State::kFault;
    d.controlword =
        clear_fault   ? delta::can::cia402::controlword_towards(d.state, true, d.controlword)
        : quick_stop_ ? delta::can::cia402::kQuickStop
                      : delta::can::cia402::controlword_towards(d.state, enable_, d.controlword);
    const bool driving = enable_ && d.state == State::kOperationEnabled;
    const std::int16_t torque = driving ? d.units.target_torque(d.command_current_A) : 0;
    std::array<std::uint8_t, 8> data{};
    pack_pdo(data, d.plan->rpdo.layout, [&](od::Object o) -> std::int64_t {
      switch (o.index) {
        case 0x6040:
          return d.controlword;
        case 0x6071:
          return torque;
        case 0x607A:
          return driving && d.has_reference ? d.reference_counts : d.position_counts;
        case 0x6060:
          return d.plan->mode;
        default:
          return 0;  // a dummy entry
      }
    });
    bus_.send(
        frame(d.plan->rpdo.cob_id, static_cast<std::uint8_t>(d.plan->rpdo.layout.bytes()), data));
  }
}

}  // namespace fw_linux
