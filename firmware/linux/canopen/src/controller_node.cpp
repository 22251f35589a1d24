#include "fw_linux/controller_node.hpp"

#include <algorithm>

#include "delta/can/cia402.hpp"
#include "delta/can/protocol.hpp"
#include "delta/update/image_file.hpp"

namespace fw_linux {

namespace p = delta::can::protocol;
namespace sdo = delta::can::sdo;

namespace {

// A refused model (or mode) as the SDO abort a client sees; 0x2200:4 says
// which check refused it.
delta::can::sdo::AbortCode model_abort(delta::controller::ModelRecordFault f) {
  using F = delta::controller::ModelRecordFault;
  switch (f) {
    case F::kOk:
      return sdo::kNoAbort;
    case F::kLength:
      return sdo::kAbortLengthMismatch;
    case F::kKind:
    case F::kValue:
      return sdo::kAbortValueRange;
    case F::kGeometry:
    case F::kDetector:
      return sdo::kAbortParameterIncompatible;
    case F::kBusy:
      return sdo::kAbortDeviceState;
    case F::kFormat:
    case F::kChecksum:
    case F::kNotStored:
      return sdo::kAbortCannotStore;
  }
  return sdo::kAbortGeneral;
}

}  // namespace

namespace {

static_assert(p::kNmtStateOperational == 5);

// The log frames LOG_A, LOG_B, LOG_C are node 16's TPDO1-3.
constexpr std::uint32_t log_cob_id(unsigned tpdo) {
  return tpdo == 0 ? p::kLogA.base_id : (tpdo == 1 ? p::kLogB.base_id : p::kLogC.base_id);
}

constexpr std::uint32_t kSyncProducer = 1u << 30;  // 0x1005 bit 30

// TPDO1-3's mapping (0x1A00-0x1A02): each log frame is the sequence and
// stale flag (0x2100, 16 bits), then two of the six logged values
// (0x2101:1-3 the angles, 0x2102:1-3 the torques, 24 bits each), in the
// order of the protocol table's signals.
constexpr std::uint32_t mapping_entry(std::uint16_t index, std::uint8_t sub, std::uint8_t bits) {
  return std::uint32_t{index} << 16 | std::uint32_t{sub} << 8 | bits;
}
constexpr std::uint32_t kMapSeq = mapping_entry(0x2100, 0, 16);
constexpr std::uint32_t kLogMapping[3][3] = {
    {kMapSeq, mapping_entry(0x2101, 1, 24), mapping_entry(0x2101, 2, 24)},
    {kMapSeq, mapping_entry(0x2101, 3, 24), mapping_entry(0x2102, 1, 24)},
    {kMapSeq, mapping_entry(0x2102, 2, 24), mapping_entry(0x2102, 3, 24)}};
static_assert(p::kLogAQ1.start_bit == 16 && p::kLogAQ2.start_bit == 40 && p::kLogAQ1.length == 24 &&
              p::kLogASeq.length + p::kLogAStale.length == 16);

// The latest record's logged values as 0x2101:1-3 (angles) and 0x2102:1-3
// (torques) give them: 24-bit two's complement.
std::uint32_t logged_value(const std::array<std::array<std::uint8_t, 8>, 3>& frames,
                           unsigned value) {
  static constexpr const p::Signal* kSignals[6] = {&p::kLogAQ1,   &p::kLogAQ2,   &p::kLogBQ3,
                                                   &p::kLogBTau1, &p::kLogCTau2, &p::kLogCTau3};
  static constexpr unsigned kFrame[6] = {0, 0, 1, 1, 2, 2};
  return static_cast<std::uint32_t>(p::unpack(frames[kFrame[value]], *kSignals[value])) & 0xFFFFFFu;
}

// TPDO5 and TPDO6's (0x1A04, 0x1A05): LOG_D and LOG_E, the sequence and
// stale flag, then the arm angles 0x2104:1-3.
constexpr std::uint32_t kArmLogMapping[2][3] = {
    {kMapSeq, mapping_entry(0x2104, 1, 24), mapping_entry(0x2104, 2, 24)},
    {kMapSeq, mapping_entry(0x2104, 3, 24), 0}};
static_assert(p::kLogDQa1.start_bit == 16 && p::kLogDQa2.start_bit == 40 &&
              p::kLogEQa3.start_bit == 16 && p::kLogEQa3.length == 24);

std::uint32_t arm_logged_value(const std::array<std::array<std::uint8_t, 8>, 2>& frames,
                               unsigned joint) {
  static constexpr const p::Signal* kSignals[3] = {&p::kLogDQa1, &p::kLogDQa2, &p::kLogEQa3};
  return static_cast<std::uint32_t>(p::unpack(frames[joint / 2], *kSignals[joint])) & 0xFFFFFFu;
}

// TPDO5 and TPDO6's COB-IDs: off (bit 31) without arm_encoders.
std::uint32_t arm_log_cob_id(bool on, const p::Message& m) {
  return m.base_id | (on ? 0u : 0x80000000u);
}

// TPDO4's mapping (0x1A03): the collision frame's four values, 0x2103:1-4.
constexpr std::uint32_t kCollisionMapping[4] = {
    mapping_entry(0x2103, 1, 8), mapping_entry(0x2103, 2, 8), mapping_entry(0x2103, 3, 24),
    mapping_entry(0x2103, 4, 24)};
static_assert(p::kCollisionJoint.start_bit == 0 && p::kCollisionTripped.start_bit == 8 &&
              p::kCollisionResidual.start_bit == 16 && p::kCollisionResidual.length == 24 &&
              p::kCollisionThreshold.start_bit == 40 && p::kCollisionThreshold.length == 24);

std::uint32_t collision_value(const std::array<std::uint8_t, 8>& frame, unsigned value) {
  static constexpr const p::Signal* kSignals[4] = {&p::kCollisionJoint, &p::kCollisionTripped,
                                                   &p::kCollisionResidual, &p::kCollisionThreshold};
  return static_cast<std::uint32_t>(p::unpack(frame, *kSignals[value])) &
         (kSignals[value]->length == 24 ? 0xFFFFFFu : 0xFFu);
}

// A Q12.19 torque in the log's 2^-16 N m, rounded, within a 24-bit
// signal: signed (-2^23 .. 2^23 - 1) or not (0 .. 2^24 - 1).
std::int64_t log_torque(delta::fx::Q12_19 v, bool is_signed) {
  const std::int64_t r = (std::int64_t{v.raw()} + 4) >> 3;
  return is_signed
             ? std::clamp<std::int64_t>(r, -(std::int64_t{1} << 23), (std::int64_t{1} << 23) - 1)
             : std::clamp<std::int64_t>(r, 0, (std::int64_t{1} << 24) - 1);
}

}  // namespace

StepReport step_report(fw::State state, fw::Fault fault, std::uint32_t cycle,
                       const fw::SafetyOutputs& outputs, const fw::CollisionEvent* collision) {
  StepReport r;
  r.collision = collision;
  r.fault = fault;
  r.cycle = cycle;
  r.ready = state == fw::State::kReady;
  r.safe_to_update = state != fw::State::kRunning && state != fw::State::kStopping &&
                     !outputs.drive_enable && !outputs.brake_release;
  return r;
}

// The objects, in index order (docs/protocol.md, docs/eds/delta_fw.eds).
std::span<const ControllerNode::Table::Scalar> ControllerNode::scalars() {
  static const Table::Scalar kScalars[] = {
      {0x1000, 0, 4, [](const Context&) { return 0u; }, nullptr},  // no standard profile
      {0x1001, 0, 1, [](const Context& c) { return c.node.fault_ == fw::Fault::kNone ? 0u : 1u; },
       nullptr},
      // The SYNC producer (CiA 301), as configured: COB-ID (bit 30: this
      // node produces it), cycle period, counter overflow value.
      {0x1005, 0, 4, [](const Context&) { return kSyncProducer | p::kSync.base_id; }, nullptr},
      {0x1006, 0, 4, [](const Context& c) { return c.node.period_us_; }, nullptr},
      {0x1017, 0, 2, [](const Context& c) { return std::uint32_t{c.node.heartbeat_ms_}; },
       [](Context& c, std::uint32_t v) {
         c.node.heartbeat_ms_ = static_cast<std::uint16_t>(v);
         c.node.since_heartbeat_us_ = 0;
         return sdo::kNoAbort;
       }},
      {0x1018, 0, 1, [](const Context&) { return 4u; }, nullptr},
      {0x1018, 1, 4, [](const Context&) { return kControllerVendorId; }, nullptr},
      {0x1018, 2, 4, [](const Context&) { return kControllerProductCode; }, nullptr},
      {0x1018, 3, 4, [](const Context& c) { return controller_identity(c.node.version_).revision; },
       nullptr},
      {0x1018, 4, 4, [](const Context&) { return 0u; }, nullptr},
      {0x1019, 0, 1, [](const Context& c) { return std::uint32_t{c.node.sync_counter_overflow_}; },
       nullptr},
      {0x1800, 0, 1, [](const Context&) { return 2u; }, nullptr},
      {0x1800, 1, 4, [](const Context&) { return log_cob_id(0); }, nullptr},
      {0x1800, 2, 1, [](const Context&) { return 1u; }, nullptr},  // every SYNC
      {0x1801, 0, 1, [](const Context&) { return 2u; }, nullptr},
      {0x1801, 1, 4, [](const Context&) { return log_cob_id(1); }, nullptr},
      {0x1801, 2, 1, [](const Context&) { return 1u; }, nullptr},
      {0x1802, 0, 1, [](const Context&) { return 2u; }, nullptr},
      {0x1802, 1, 4, [](const Context&) { return log_cob_id(2); }, nullptr},
      {0x1802, 2, 1, [](const Context&) { return 1u; }, nullptr},
      // TPDO4, the collision frames: event-driven (254), sent by the node.
      {0x1803, 0, 1, [](const Context&) { return 2u; }, nullptr},
      {0x1803, 1, 4, [](const Context&) { return std::uint32_t{p::kCollision.base_id}; }, nullptr},
      {0x1803, 2, 1, [](const Context&) { return 254u; }, nullptr},
      // TPDO5 and TPDO6, the arm-side encoders' log frames (arm_encoders).
      {0x1804, 0, 1, [](const Context&) { return 2u; }, nullptr},
      {0x1804, 1, 4,
       [](const Context& c) { return arm_log_cob_id(c.node.arm_encoders_, p::kLogD); }, nullptr},
      {0x1804, 2, 1, [](const Context&) { return 1u; }, nullptr},
      {0x1805, 0, 1, [](const Context&) { return 2u; }, nullptr},
      {0x1805, 1, 4,
       [](const Context& c) { return arm_log_cob_id(c.node.arm_encoders_, p::kLogE); }, nullptr},
      {0x1805, 2, 1, [](const Context&) { return 1u; }, nullptr},
      {0x1A00, 0, 1, [](const Context&) { return 3u; }, nullptr},
      {0x1A00, 1, 4, [](const Context&) { return kLogMapping[0][0]; }, nullptr},
      {0x1A00, 2, 4, [](const Context&) { return kLogMapping[0][1]; }, nullptr},
      {0x1A00, 3, 4, [](const Context&) { return kLogMapping[0][2]; }, nullptr},
      {0x1A01, 0, 1, [](const Context&) { return 3u; }, nullptr},
      {0x1A01, 1, 4, [](const Context&) { return kLogMapping[1][0]; }, nullptr},
      {0x1A01, 2, 4, [](const Context&) { return kLogMapping[1][1]; }, nullptr},
      {0x1A01, 3, 4, [](const Context&) { return kLogMapping[1][2]; }, nullptr},
      {0x1A02, 0, 1, [](const Context&) { return 3u; }, nullptr},
      {0x1A02, 1, 4, [](const Context&) { return kLogMapping[2][0]; }, nullptr},
      {0x1A02, 2, 4, [](const Context&) { return kLogMapping[2][1]; }, nullptr},
      {0x1A02, 3, 4, [](const Context&) { return kLogMapping[2][2]; }, nullptr},
      {0x1A03, 0, 1, [](const Context&) { return 4u; }, nullptr},
      {0x1A03, 1, 4, [](const Context&) { return kCollisionMapping[0]; }, nullptr},
      {0x1A03, 2, 4, [](const Context&) { return kCollisionMapping[1]; }, nullptr},
      {0x1A03, 3, 4, [](const Context&) { return kCollisionMapping[2]; }, nullptr},
      {0x1A03, 4, 4, [](const Context&) { return kCollisionMapping[3]; }, nullptr},
      {0x1A04, 0, 1, [](const Context&) { return 3u; }, nullptr},
      {0x1A04, 1, 4, [](const Context&) { return kArmLogMapping[0][0]; }, nullptr},
      {0x1A04, 2, 4, [](const Context&) { return kArmLogMapping[0][1]; }, nullptr},
      {0x1A04, 3, 4, [](const Context&) { return kArmLogMapping[0][2]; }, nullptr},
      {0x1A05, 0, 1, [](const Context&) { return 2u; }, nullptr},
      {0x1A05, 1, 4, [](const Context&) { return kArmLogMapping[1][0]; }, nullptr},
      {0x1A05, 2, 4, [](const Context&) { return kArmLogMapping[1][1]; }, nullptr},
      // Program download (CiA 302-3): one program, 0x1F50:1 (a domain, below).
      {0x1F50, 0, 1, [](const Context&) { return 1u; }, nullptr},
      {0x1F51, 0, 1, [](const Context&) { return 1u; }, nullptr},
      {0x1F51, 1, 1, [](const Context&) { return 1u; },  // reads 1: this program runs
       [](Context& c, std::uint32_t v) {
         return c.node.program_.control(v, c.node.safe_to_update_);
       }},
      {0x1F56, 0, 1, [](const Context&) { return 1u; }, nullptr},
      {0x1F56, 1, 4, [](const Context& c) { return c.node.program_.program_crc32(); }, nullptr},
      {0x1F57, 0, 1, [](const Context&) { return 1u; }, nullptr},
      {0x1F57, 1, 4, [](const Context& c) { return c.node.program_.flash_status(); }, nullptr},
      // The latest log record, as TPDO1-3 map it.
      {0x2100, 0, 2,
       [](const Context& c) {
         const auto& a = c.node.log_frames_[0];
         return std::uint32_t{a[0]} | std::uint32_t{a[1]} << 8;
       },
       nullptr, true},
      {0x2101, 0, 1, [](const Context&) { return 3u; }, nullptr},
      {0x2101, 1, 3, [](const Context& c) { return logged_value(c.node.log_frames_, 0); }, nullptr,
       true},
      {0x2101, 2, 3, [](const Context& c) { return logged_value(c.node.log_frames_, 1); }, nullptr,
       true},
      {0x2101, 3, 3, [](const Context& c) { return logged_value(c.node.log_frames_, 2); }, nullptr,
       true},
      {0x2102, 0, 1, [](const Context&) { return 3u; }, nullptr},
      {0x2102, 1, 3, [](const Context& c) { return logged_value(c.node.log_frames_, 3); }, nullptr,
       true},
      {0x2102, 2, 3, [](const Context& c) { return logged_value(c.node.log_frames_, 4); }, nullptr,
       true},
      {0x2102, 3, 3, [](const Context& c) { return logged_value(c.node.log_frames_, 5); }, nullptr,
       true},
      // The last collision frame sent (TPDO4; 0 before one).
      {0x2103, 0, 1, [](const Context&) { return 4u; }, nullptr},
      {0x2103, 1, 1, [](const Context& c) { return collision_value(c.node.collision_frame_, 0); },
       nullptr, true},
      {0x2103, 2, 1, [](const Context& c) { return collision_value(c.node.collision_frame_, 1); },
       nullptr, true},
      {0x2103, 3, 3, [](const Context& c) { return collision_value(c.node.collision_frame_, 2); },
       nullptr, true},
      {0x2103, 4, 3, [](const Context& c) { return collision_value(c.node.collision_frame_, 3); },
       nullptr, true},
      // The latest record's arm angles, as TPDO5 and TPDO6 map them.
      {0x2104, 0, 1, [](const Context&) { return 3u; }, nullptr},
      {0x2104, 1, 3, [](const Context& c) { return arm_logged_value(c.node.arm_log_frames_, 0); },
       nullptr, true},
      {0x2104, 2, 3, [](const Context& c) { return arm_logged_value(c.node.arm_log_frames_, 1); },
       nullptr, true},
      {0x2104, 3, 3, [](const Context& c) { return arm_logged_value(c.node.arm_log_frames_, 2); },
       nullptr, true},
      // The feed-forward: the fit id of the model in use, the mode, the last
      // load's verdict (0x2200:1, the model itself, is a domain below).
      {0x2200, 0, 1, [](const Context&) { return 4u; }, nullptr},
      {0x2200, 2, 4, [](const Context& c) { return c.node.feed_forward_.fit_id(); }, nullptr},
      {0x2200, 3, 1,
       [](const Context& c) {
         return static_cast<std::uint32_t>(c.node.feed_forward_.current().mode);
       },
       [](Context& c, std::uint32_t v) {
         return model_abort(c.node.feed_forward_.set_mode(v, c.node.safe_to_update_));
       }},
      {0x2200, 4, 1,
       [](const Context& c) {
         return static_cast<std::uint32_t>(c.node.feed_forward_.last_load());
       },
       nullptr},
      // How this program runs under delta_boot, and the last roll-back's reason.
      {0x2F00, 0, 1, [](const Context&) { return 3u; }, nullptr},
      {0x2F00, 1, 1,
       [](const Context& c) {
         return std::uint32_t{static_cast<std::uint8_t>(c.node.program_.boot_status())};
       },
       nullptr},
      {0x2F00, 2, 1,
       [](const Context& c) {
         return std::uint32_t{static_cast<std::uint8_t>(c.node.program_.reverted())};
       },
       nullptr},
      {0x2F00, 3, 4, [](const Context& c) { return c.node.program_.key_fingerprint(); }, nullptr},
  };
  return kScalars;
}

std::span<const ControllerNode::Table::Text> ControllerNode::texts() {
  static const Table::Text kTexts[] = {
      {0x1008, 0, [](const Context&) { return std::string("delta_fw"); }},
      {0x1009, 0, [](const Context&) { return std::string("Linux"); }},
      {0x100A, 0, [](const Context& c) { return delta::update::version_text(c.node.version_); }},
  };
  return kTexts;
}

std::span<const ControllerNode::Table::Domain> ControllerNode::domains() {
  static const Table::Domain kDomains[] = {
      {0x1F50, 1, [](const Context& c) { return c.node.program_.capacity_bytes(); },
       [](Context& c, std::uint32_t offset, std::span<const std::uint8_t> data, bool last) {
         return c.node.program_.write(offset, data, last, c.node.safe_to_update_);
       },
       [](Context& c) { c.node.program_.abandoned(); }},
      {0x2200, 1,
       [](const Context&) { return std::uint32_t{delta::controller::kModelRecordBytes}; },
       [](Context& c, std::uint32_t offset, std::span<const std::uint8_t> data, bool last) {
         return c.node.model_piece(offset, data, last);
       },
       [](Context& c) { c.node.model_download_bytes_ = 0; },
       [](const Context& c) { return c.node.feed_forward_.record(); }},
  };
  return kDomains;
}

ControllerNode::ControllerNode(FrameSink& bus, const PortConfig& c,
                               const delta::update::Version& version, ProgramDownload& program,
                               FeedForwardSlot& feed_forward)
    : bus_(bus),
      version_(version),
      program_(program),
      feed_forward_(feed_forward),
      period_us_(c.period_us),
      sync_counter_overflow_(c.sync_counter_overflow),
      configured_heartbeat_ms_(static_cast<std::uint16_t>(c.heartbeat_ms)),
      heartbeat_ms_(configured_heartbeat_ms_),
      arm_encoders_(c.arm_encoders),
      table_(Context{*this}, scalars(), texts(), domains()) {
  server_.emplace(table_);
}

// A piece of a model download: gathered until the last, which hands the
// whole record to the slot (a transfer that never ends changes nothing).
sdo::AbortCode ControllerNode::model_piece(std::uint32_t offset, std::span<const std::uint8_t> data,
                                           bool last) {
  if (offset == 0) model_download_bytes_ = 0;
  const bool out_of_order = offset != model_download_bytes_;
  if (out_of_order || offset + data.size() > model_download_.size()) {
    model_download_bytes_ = 0;
    feed_forward_.note_refused_download(out_of_order ? "a piece out of order, abort 0x06070012"
                                                     : "longer than a record (" +
                                                           std::to_string(model_download_.size()) +
                                                           " bytes), abort 0x06070012");
    return sdo::kAbortLengthTooHigh;
  }
  std::copy(data.begin(), data.end(), model_download_.begin() + offset);
  model_download_bytes_ += static_cast<std::uint32_t>(data.size());
  if (!last) return sdo::kNoAbort;
  const std::uint32_t n = model_download_bytes_;
  model_download_bytes_ = 0;
  return model_abort(feed_forward_.load(std::span(model_download_.data(), n), safe_to_update_));
}

std::string ControllerNode::eds_mismatch(const delta::canopen::Eds& eds) {
  return table_.mismatch(eds, "the controller");
}

void ControllerNode::on_frame(const delta::can::Frame& f, std::uint64_t now_us) {
  if (f.extended || f.remote || f.error_frame) return;
  if (f.id == p::cob_id(p::kNmt, 0)) return handle_nmt(f);
  if (f.id != p::cob_id(p::kSdoRx, p::kControllerNode) || f.dlc != 8) return;
  if (nmt_ == p::kNmtStateStopped) return;  // CiA 301: NMT and error control only
  server_->on_frame(f.data, now_us);
  flush_sdo(now_us);
}

void ControllerNode::handle_nmt(const delta::can::Frame& f) {
  if (f.dlc != 2 || (f.data[1] != 0 && f.data[1] != p::kControllerNode)) return;
  switch (f.data[0]) {
    case p::kNmtStart:
      nmt_ = kOperational;
      break;
    case p::kNmtStop:
      nmt_ = p::kNmtStateStopped;
      break;
    case p::kNmtEnterPreOperational:
      nmt_ = p::kNmtStatePreOperational;
      break;
    case p::kNmtResetNode:
    case p::kNmtResetCommunication:
      reset_communication();
      break;
    default:
      break;
  }
}

// The communication objects back to the configuration, a transfer in
// progress dropped, the boot-up message; then it starts itself again.
void ControllerNode::reset_communication() {
  heartbeat_ms_ = configured_heartbeat_ms_;
  since_heartbeat_us_ = 0;
  server_.emplace(table_);
  boot_up_due_ = true;
}

void ControllerNode::flush_sdo(std::uint64_t now_us) {
  sdo::Payload reply;
  while (server_->pending(reply)) {
    send(p::cob_id(p::kSdoTx, p::kControllerNode), 8, reply);
    server_->sent(now_us);
  }
}

void ControllerNode::after_step(const StepReport& step, std::uint64_t now_us) {
  if (boot_up_due_) {
    send(p::kControllerHeartbeat.base_id, p::kControllerHeartbeat.dlc, {p::kNmtStateBootUp});
    boot_up_due_ = false;
    nmt_ = kOperational;
  }
  fault_ = step.fault;
  safe_to_update_ = step.safe_to_update;
  program_.after_step(step.ready);
  if (!revert_reported_ && nmt_ != p::kNmtStateStopped) {
    revert_reported_ = true;
    if (program_.reverted() != fw::update::RevertReason::kNone) {
      emergency(delta::can::od::kEmcyUpdateRolledBack,
                static_cast<std::uint16_t>(program_.reverted()), step.cycle);
    }
  }
  if (step.fault != last_reported_ && nmt_ != p::kNmtStateStopped) {
    const std::uint16_t code =
        step.fault == fw::Fault::kNone
            ? delta::can::od::kEmcyErrorReset
            : static_cast<std::uint16_t>(delta::can::od::kEmcyControllerFaultBase +
                                         static_cast<std::uint16_t>(step.fault));
    emergency(code, static_cast<std::uint16_t>(step.fault), step.cycle);
    last_reported_ = step.fault;
    if (step.fault == fw::Fault::kCollision && step.collision != nullptr && nmt_ == kOperational) {
      collision_frames(*step.collision);
    }
  }
  since_heartbeat_us_ += period_us_;
  if (heartbeat_ms_ != 0 && since_heartbeat_us_ >= std::uint32_t{heartbeat_ms_} * 1000u) {
    since_heartbeat_us_ = 0;
    send(p::kControllerHeartbeat.base_id, p::kControllerHeartbeat.dlc, {nmt_});
  }
  server_->tick(now_us);
  flush_sdo(now_us);
}

// A collision's residuals and thresholds: TPDO4 once per joint.
void ControllerNode::collision_frames(const fw::CollisionEvent& e) {
  for (unsigned j = 0; j < 3; ++j) {
    std::array<std::uint8_t, 8> d{};
    p::pack(d, p::kCollisionJoint, j + 1);
    p::pack(d, p::kCollisionTripped, e.joint + 1u);
    p::pack(d, p::kCollisionResidual, log_torque(e.residual_Nm[j], true));
    p::pack(d, p::kCollisionThreshold, log_torque(e.threshold_Nm[j], false));
    collision_frame_ = d;
    send(p::kCollision.base_id, p::kCollision.dlc, d);
  }
}

// The error register's generic bit (CiA 301) is set for any code but the reset.
void ControllerNode::emergency(std::uint16_t code, std::uint16_t fault_code, std::uint32_t cycle) {
  std::array<std::uint8_t, 8> d{};
  p::pack(d, p::kControllerEmcyErrorCode, code);
  p::pack(d, p::kControllerEmcyErrorRegister, code == delta::can::od::kEmcyErrorReset ? 0 : 1);
  p::pack(d, p::kControllerEmcyFaultCode, fault_code);
  p::pack(d, p::kControllerEmcyCycle, cycle);
  send(p::kControllerEmcy.base_id, p::kControllerEmcy.dlc, d);
}

void ControllerNode::send(std::uint32_t id, std::uint8_t dlc,
                          const std::array<std::uint8_t, 8>& data) {
  delta::can::Frame f;
  f.id = id;
  f.dlc = dlc;
  f.data = data;
  bus_.send(f);
}

}  // namespace fw_linux
