#include "fw_linux/canopen_master.hpp"

#include <algorithm>
#include <cstdio>
#include <optional>

#include "delta/can/emcy.hpp"
#include "delta/can/protocol.hpp"
#include "fw/torque_from_current.hpp"
#include "fw_linux/bring_up.hpp"

namespace fw_linux {

namespace p = delta::can::protocol;
namespace od = delta::can::od;
namespace sdo = delta::can::sdo;
using delta::can::Frame;
using delta::can::cia402::State;

namespace {

od::Object object_of(unsigned step, unsigned mapping_write) {
  return mapping_step(step) ? mapping_writes(step)[mapping_write].object : kBringUp[step].object;
}

std::string hex(std::uint32_t v, int digits) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%0*X", digits, v);
  return b;
}

std::string object_name(od::Object o) {
  return hex(o.index, 4) + ":" + hex(o.subindex, 2).substr(2);
}

Frame frame(std::uint32_t id, std::uint8_t dlc, const std::array<std::uint8_t, 8>& data) {
  Frame f;
  f.id = id;
  f.dlc = dlc;
  f.data = data;
  return f;
}

}  // namespace

CanopenMaster::CanopenMaster(const PortConfig& config, FrameSink& bus)
    : config_(config), core_(controller_config(config)), bus_(bus) {
  // In lock-step a slow machine must not look like a silent drive: an SDO
  // answer is awaited at least as long as a PDO answer.
  const std::uint32_t sdo_ms = config.mode == CycleMode::kLockStep
                                   ? std::max(config.sdo_timeout_ms, config.lockstep_timeout_ms)
                                   : config.sdo_timeout_ms;
  sdo_timeout_us_ = std::uint64_t{sdo_ms} * 1000;
  for (unsigned j = 0; j < 3; ++j) {
    drives_[j].node = config.joints[j].node;
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
  phase_ = Phase::kFailed;
  bring_up_problem_ = why;
  cyclic_problem_.kind = CyclicProblem::Kind::kNone;
}

void CanopenMaster::restart() {
  for (Drive& d : drives_) {
    const std::uint8_t node = d.node;
    d = Drive{};
    d.node = node;
    d.sdo = sdo::Client(static_cast<std::uint32_t>(sdo_timeout_us_));
  }
  phase_ = Phase::kIdle;
  failure_reported_ = false;
  bus_error_ = false;
  clear_problem();
}

// The value a bring-up step writes, and its size in bytes (0: a read).
std::uint32_t CanopenMaster::step_value(const Drive& d, std::uint8_t& size) const {
  switch (d.sdo_step) {
    case kWriteMode:
      size = 1;
      return delta::can::cia402::kModeCyclicSynchronousTorque;
    case kClearCyclePeriod:
      size = 4;
      return 0;
    case kWriteSyncCounter:
      size = 1;
      return config_.sync_counter_overflow;
    case kWriteCyclePeriod:
      size = 4;
      return config_.period_us;
    case kWriteHeartbeat:
      size = 2;
      return config_.heartbeat_ms;
    case kWriteConsumerHeartbeat:
      // A timeout of 0 turns the drive's supervision off (CiA 301).
      size = 4;
      return od::consumer_heartbeat(p::kControllerNode, config_.controller_heartbeat_timeout_ms);
    case kWritePdoMapping:
    case kWriteSyncPdoMapping: {
      const PdoMappingWrite& w = mapping_writes(d.sdo_step)[d.mapping_write];
      size = w.size;
      return w.node_relative ? w.value + d.node : w.value;
    }
    case kWriteTpdo2: {
      size = 4;
      const std::uint32_t cob = p::cob_id(p::kTpdo2, d.node);
      return config_.velocity_pdo ? cob : (cob | od::kPdoInvalid);
    }
    default:
      size = 0;
      return 0;
  }
}

void CanopenMaster::send_sdo(Drive& d, std::uint64_t now_us) {
  const od::Object o = object_of(d.sdo_step, d.mapping_write);
  std::uint8_t size = 0;
  const std::uint32_t value = step_value(d, size);
  if (size == 0) {
    d.sdo.upload(o.index, o.subindex, d.sdo_bytes, sdo::Transfer::kAuto, now_us);
  } else {
    for (unsigned i = 0; i < 4; ++i) d.sdo_bytes[i] = static_cast<std::uint8_t>(value >> (8 * i));
    d.sdo.download(o.index, o.subindex, std::span(d.sdo_bytes).first(size), sdo::Transfer::kAuto,
                   now_us);
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
    if (d.sdo_step >= kBringUpStepCount) continue;
    all_done = false;
    d.sdo.tick(now_us_);
    pump_sdo(d);
    if (d.sdo.status() == sdo::ClientStatus::kBusy) continue;
    if (d.sdo.status() == sdo::ClientStatus::kAborted && d.sdo_attempts > config_.sdo_retries) {
      const od::Object o = object_of(d.sdo_step, d.mapping_write);
      fail("node " + std::to_string(d.node) + ": no answer to the SDO request for " +
           object_name(o) + " within " + std::to_string(sdo_timeout_us_ / 1000) + " ms (" +
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

void CanopenMaster::handle_sdo_response(Drive& d, const Frame& f) {
  if (d.sdo.status() != sdo::ClientStatus::kBusy) return;  // a duplicate or stray answer
  const od::Object o = object_of(d.sdo_step, d.mapping_write);
  const std::string at = "node " + std::to_string(d.node) + ", " + object_name(o) + ": ";
  if (f.dlc != 8) return fail(at + "SDO response with " + std::to_string(f.dlc) + " bytes");
  d.sdo.on_frame(f.data, now_us_);
  pump_sdo(d);
  if (d.sdo.status() == sdo::ClientStatus::kBusy) return;
  if (d.sdo.status() == sdo::ClientStatus::kAborted) {
    const std::uint32_t code = d.sdo.abort_code();
    if (d.sdo.aborted_by_server()) {
      return fail(at + "the drive aborted the transfer: " + hex(code, 8) + " (" +
                  sdo::abort_meaning(code) + ")");
    }
    return fail(at + "unexpected SDO response, command byte " + hex(f.data[0], 2) + " (" +
                sdo::abort_meaning(code) + ")");
  }
  std::uint32_t value = 0;
  for (unsigned i = 0; i < d.sdo.uploaded_size() && i < 4; ++i) {
    value |= std::uint32_t{d.sdo_bytes[i]} << (8 * i);
  }
  take_step_result(d, value, at);
}

// A bring-up step's answer: what was read is checked and kept; then the
// next step.
void CanopenMaster::take_step_result(Drive& d, std::uint32_t value, const std::string& at) {
  switch (d.sdo_step) {
    case kReadDeviceType:
      if ((value & 0xFFFF) != (od::kDeviceTypeServo & 0xFFFF)) {
        return fail(at + "device type " + hex(value, 8) + " is not a CiA 402 drive (0x....0192)");
      }
      break;
    case kReadVendorId:
    case kReadProductCode:
    case kReadRevisionNumber:
    case kReadSerialNumber:
      if (!identity_matches(d, value, at)) return;
      break;
    case kReadRatedCurrent:
      if (value == 0) return fail(at + "the drive reports a rated current of 0 mA");
      d.rated_current_mA = value;
      break;
    case kReadRatedTorque:
      if (value == 0) return fail(at + "the drive reports a rated torque of 0 mN m");
      d.rated_torque_mNm = value;
      break;
    case kReadEncoderIncrements:
      if (value != joint(d).model.counts_per_rev) {
        return fail(at + "the encoder has " + std::to_string(value) +
                    " counts per revolution; the configuration says " +
                    std::to_string(joint(d).model.counts_per_rev) + " (joint" +
                    std::to_string(&d - drives_.data() + 1) + ".counts_per_rev)");
      }
      d.units = DriveUnits(joint(d).model, d.rated_current_mA, d.rated_torque_mNm);
      break;
    default:
      break;
  }
  d.sdo_attempts = 0;
  if (mapping_step(d.sdo_step) && ++d.mapping_write < mapping_writes(d.sdo_step).size()) {
    return send_sdo(d, now_us_);  // the mapping's next write
  }
  d.mapping_write = 0;
  next_step(d);
  if (d.sdo_step < kBringUpStepCount) send_sdo(d, now_us_);
}

// The vendor ID is always read (0x1018:1 is mandatory); the product code,
// revision and serial number only when the configuration expects them.
void CanopenMaster::next_step(Drive& d) const {
  const DriveIdentity& id = joint(d).identity;
  for (++d.sdo_step; d.sdo_step < kBringUpStepCount; ++d.sdo_step) {
    const bool skip = (d.sdo_step == kReadProductCode && !id.product_code) ||
                      (d.sdo_step == kReadRevisionNumber && !id.revision) ||
                      (d.sdo_step == kReadSerialNumber && !id.serial) ||
                      (sync_counter_step(d.sdo_step) && !counted());
    if (!skip) return;
  }
}

// 0x1018 against the configuration: the vendor ID, product code and serial
// number exactly, the revision by its major part (CiA 301: the minor part
// changes without changing the CANopen behaviour).
bool CanopenMaster::identity_matches(Drive& d, std::uint32_t found, const std::string& at) {
  const DriveIdentity& id = joint(d).identity;
  const std::optional<std::uint32_t> expected[] = {id.vendor_id, id.product_code, id.revision,
                                                   id.serial};
  const std::optional<std::uint32_t>& want = expected[d.sdo_step - kReadVendorId];
  if (!want) return true;
  const bool revision = d.sdo_step == kReadRevisionNumber;
  const bool same = revision ? (found >> 16) == (*want >> 16) : found == *want;
  if (same) return true;
  fail(at + std::string(kBringUp[d.sdo_step].what) + " " + hex(found, 8) + "; " + id.source +
       " expects " + hex(*want, 8) +
       (revision ? " (major revision " + std::to_string(*want >> 16) + ")" : "") +
       ": is this the drive the configuration describes?");
  return false;
}

// A TPDO in the cycle's window: TPDO1 and TPDO2 are held; without a SYNC
// counter they count at once, with one when TPDO3 confirms the cycle.
void CanopenMaster::handle_tpdo(Drive& d, const Frame& f, unsigned pdo) {
  static constexpr const p::Message* kTpdos[] = {&p::kTpdo1, &p::kTpdo2, &p::kTpdo3};
  const std::uint8_t expected = kTpdos[pdo - 1]->dlc;
  const auto number = static_cast<std::uint8_t>(pdo);
  if (f.dlc != expected) {
    d.malformed = true;
    if (pdo == 1) d.got_tpdo1 = true;  // answered, if badly
    if (pdo == 2) d.got_tpdo2 = true;
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
  if (pdo == 3) return take_sync_echo(d, f);
  if (pdo == 2) {
    d.held.velocity_counts_s =
        static_cast<std::int32_t>(p::unpack(f.data, p::kTpdo2VelocityActual));
    d.held.tpdo2 = true;
  } else {
    d.held.statusword = static_cast<std::uint16_t>(p::unpack(f.data, p::kTpdo1Statusword));
    d.held.position_counts = static_cast<std::int32_t>(p::unpack(f.data, p::kTpdo1PositionActual));
    d.held.current_per_mille = static_cast<std::int16_t>(p::unpack(f.data, p::kTpdo1CurrentActual));
    d.held.tpdo1 = true;
  }
  if (!counted()) take_held(d);
}

// TPDO3: the counter of the SYNC the drive's held TPDOs answer. Another
// SYNC's counter means they are an earlier cycle's, late: dropped.
void CanopenMaster::take_sync_echo(Drive& d, const Frame& f) {
  const auto counter = static_cast<std::uint8_t>(p::unpack(f.data, p::kTpdo3SyncCounter));
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

void CanopenMaster::take_held(Drive& d) {
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
  d.held = {};
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
  if (function == p::kSdoTx.base_id) {
    handle_sdo_response(*d, f);
  } else if (function == p::kTpdo1.base_id) {
    if (cyclic()) handle_tpdo(*d, f, 1);
  } else if (function == p::kTpdo2.base_id) {
    if (cyclic()) handle_tpdo(*d, f, 2);
  } else if (function == p::kTpdo3.base_id) {
    if (cyclic() && counted()) handle_tpdo(*d, f, 3);
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
    d.got_tpdo1 = d.got_tpdo2 = false;
    d.held = {};
  }
  window_open_ = cyclic();
  if (!window_open_) return;
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
    if (!d.got_tpdo1 || (config_.velocity_pdo && !d.got_tpdo2)) return false;
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
    fb.current_A = d.units.current(d.current_per_mille);
    fb.fresh = sample && (!config_.velocity_pdo || d.got_tpdo2) && heartbeat_ok;
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
      return node + ": no TPDO1 answered the SYNC of cycle " + std::to_string(p.cycle);
    case Kind::kSilentAfterStart:
      return node + " sends no TPDO1 after the NMT start";
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

void CanopenMaster::send_commands() {
  if (!cyclic()) return;
  for (Drive& d : drives_) {
    // While starting, only a fault-reset edge for a drive in fault.
    const bool clear_fault = phase_ == Phase::kStarting && d.state == State::kFault;
    d.controlword = clear_fault
                        ? delta::can::cia402::controlword_towards(d.state, true, d.controlword)
                        : delta::can::cia402::controlword_towards(d.state, enable_, d.controlword);
    const bool driving = enable_ && d.state == State::kOperationEnabled;
    std::array<std::uint8_t, 8> data{};
    p::pack(data, p::kRpdo1Controlword, d.controlword);
    p::pack(data, p::kRpdo1TargetTorque,
            driving ? d.units.target_torque_per_mille(d.command_current_A) : 0);
    p::pack(data, p::kRpdo1TargetPosition, d.position_counts);
    bus_.send(frame(p::cob_id(p::kRpdo1, d.node), 8, data));
  }
}

}  // namespace fw_linux
