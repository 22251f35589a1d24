// The Modbus server's register bank: the settings, the status snapshot and
// the validation of writes, for the TCP and RTU transports alike.
#include <modbus/modbus.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <string_view>

#include "delta/controller/vocabulary.hpp"
#include "fw_linux/modbus_server.hpp"
#include "fw_linux/rtu_framer.hpp"
#include "fw_linux/trajectories.hpp"

namespace fw_linux {

namespace mb = delta::modbus;

namespace {

constexpr std::uint8_t kReadHolding = 0x03;
constexpr std::uint8_t kReadInput = 0x04;
constexpr std::uint8_t kWriteSingle = 0x06;
constexpr std::uint8_t kWriteMultiple = 0x10;
constexpr unsigned kMaxReadCount = 125;   // Modbus: registers per read
constexpr unsigned kMaxWriteCount = 123;  // Modbus: registers per write

// An exception reply. libmodbus adds 0x80 to the request's function code in
// an int and stores a byte, so a request with a code of 0x80 or more (no
// such function exists) got a reply with the code's low 7 bits: 0x83 was
// answered as 03. Those replies are built here, with the code as sent (its
// exception bit already set).
void reply_exception(modbus_t* ctx, const std::uint8_t* request, std::uint8_t code) {
  const int h = modbus_get_header_length(ctx);
  const std::uint8_t function = request[h];
  if (function < 0x80) {
    modbus_reply_exception(ctx, request, code);
    return;
  }
  std::uint8_t reply[9];
  std::size_t n = 0;
  if (h == 7) {  // TCP: the request's transaction and unit, a length of 3
    const std::uint8_t header[] = {request[0], request[1], 0, 0, 0, 3, request[6]};
    std::memcpy(reply, header, sizeof header);
    n = sizeof header;
  } else {  // RTU: the unit, and the CRC after the PDU
    reply[n++] = request[0];
  }
  reply[n++] = function;
  reply[n++] = code;
  if (h != 7) {
    const std::uint16_t crc = modbus_crc16(reply, n);
    reply[n++] = static_cast<std::uint8_t>(crc & 0xFF);
    reply[n++] = static_cast<std::uint8_t>(crc >> 8);
  }
  const int fd = modbus_get_socket(ctx);
  // A TCP client may be gone: no SIGPIPE for that; its next read tells.
  const ssize_t sent = h == 7 ? send(fd, reply, n, MSG_NOSIGNAL) : ::write(fd, reply, n);
  (void)sent;
}

std::uint16_t be16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

// A register by its name, found at compile time: refresh() runs on every
// read, and named() at run time compares the name with every register's.
// A name not in the map does not compile.
consteval const mb::Register& reg(std::string_view name) {
  return mb::named(name);
}

bool moving(const PanelStatus& s) {
  return s.state == fw::State::kRunning || s.state == fw::State::kStopping ||
         s.run_result == mb::RunResult::kRunning;
}

}  // namespace

RegisterBank::RegisterBank(const PortConfig& config, ControlPanel& panel,
                           const ProgramFacts& program)
    : config_(config),
      program_(program),
      core_(controller_config(config)),
      panel_(panel),
      mapping_(
          modbus_mapping_new_start_address(0, 0, 0, 0, 0, mb::kHoldingCount, 0, mb::kInputCount)) {
  if (mapping_ == nullptr) throw ModbusError("Modbus: cannot allocate the register map");
  settings_.log_enable = panel.log_enabled().load();
  if (config.custom_block.size() == settings_.custom.size()) {
    std::copy(config.custom_block.begin(), config.custom_block.end(), settings_.custom.begin());
  }
  refresh();
}

RegisterBank::~RegisterBank() {
  modbus_mapping_free(mapping_);
}

void RegisterBank::refresh() {
  refresh_inputs();
  refresh_holding();
}

void RegisterBank::refresh_inputs() {
  const PanelStatus s = panel_.status();
  std::uint16_t* in = mapping_->tab_input_registers;
  auto set = [in](const mb::Register& r, std::int64_t v) { mb::encode(r, v, in); };
  set(reg("firmware_version_major"), program_.version.major);
  set(reg("firmware_version_minor"), program_.version.minor);
  set(reg("firmware_version_patch"), program_.version.patch);
  set(reg("update_rollback"), static_cast<int>(program_.rolled_back));
  set(reg("tracking_run_id"), s.tracking_run_id);
  set(reg("tracking_ticks"), s.tracking_ticks);
  static constexpr const mb::Register* kRms[] = {&reg("tracking_rms_1"), &reg("tracking_rms_2"),
                                                 &reg("tracking_rms_3")};
  static constexpr const mb::Register* kMax[] = {&reg("tracking_max_1"), &reg("tracking_max_2"),
                                                 &reg("tracking_max_3")};
  for (unsigned j = 0; j < 3; ++j) {
    set(*kRms[j], s.tracking_rms_nrad[j]);
    set(*kMax[j], s.tracking_max_nrad[j]);
  }
  set(reg("collision_detect"), s.collision_detect ? 1 : 0);
  set(reg("collision_count"), s.collision_count);
  set(reg("collision_joint"), s.collision_joint);
  set(reg("collision_t"), s.collision_t_ms);
  static constexpr const mb::Register* kResidual[] = {
      &reg("collision_residual_1"), &reg("collision_residual_2"), &reg("collision_residual_3")};
  static constexpr const mb::Register* kThreshold[] = {
      &reg("collision_threshold_1"), &reg("collision_threshold_2"), &reg("collision_threshold_3")};
  for (unsigned j = 0; j < 3; ++j) {
    set(*kResidual[j], s.collision_residual_uNm[j]);
    set(*kThreshold[j], s.collision_threshold_uNm[j]);
  }
  set(reg("feed_forward_mode"), static_cast<int>(s.feed_forward.mode));
  set(reg("model_fit_id"), s.model_fit_id);
  set(reg("protocol_version"), mb::kMapVersion);
  set(reg("state"), static_cast<int>(s.state));
  set(reg("fault_code"), static_cast<int>(s.fault));
  set(reg("cycle_counter"), s.cycle);
  set(reg("period_us"), config_.period_us);
  set(reg("io"), s.io_bits);
  set(reg("run_id"), s.run_id);
  set(reg("run_result"), static_cast<int>(s.run_result));
  set(reg("run_tick"), s.run_tick);
  set(reg("run_length"), s.run_length);
  set(reg("log_records"), s.log_records);
  set(reg("stale_log_records"), s.stale_log_records);
  set(reg("fault_count"), s.fault_count);
  refresh_history_and_checks(s);
  auto um = [](double m) { return static_cast<std::int64_t>(m * 1e6 + 0.5); };
  set(reg("upper_arm_length"), um(config_.geometry.upper_arm_length_m));
  set(reg("forearm_length"), um(config_.geometry.forearm_length_m));
  set(reg("base_radius"), um(config_.geometry.base_radius_m));
  set(reg("platform_radius"), um(config_.geometry.platform_radius_m));
  static constexpr const mb::Register* kQ[] = {&reg("q1"), &reg("q2"), &reg("q3")};
  static constexpr const mb::Register* kTau[] = {&reg("tau1"), &reg("tau2"), &reg("tau3")};
  for (unsigned j = 0; j < 3; ++j) {
    set(*kQ[j], s.q_urad[j]);
    set(*kTau[j], s.tau_uNm[j]);
  }
  set(reg("trajectory_count"),
      static_cast<std::int64_t>(delta::controller::kTrajectoryNames.size()));
}

void RegisterBank::refresh_history_and_checks(const PanelStatus& s) {
  std::uint16_t* in = mapping_->tab_input_registers;
  auto set = [in](const mb::Register& r, std::int64_t v) { mb::encode(r, v, in); };
  static constexpr auto kHistory = [] {
    std::array<std::array<const mb::Register*, 2>, mb::kFaultHistoryLength> h{};
    for (unsigned k = 0; k < h.size(); ++k) {
      h[k] = {&mb::fault_history_code(k), &mb::fault_history_cycle(k)};
    }
    return h;
  }();
  for (unsigned k = 0; k < mb::kFaultHistoryLength; ++k) {
    set(*kHistory[k][0], static_cast<int>(s.fault_history[k].fault));
    set(*kHistory[k][1], s.fault_history[k].cycle);
  }
  set(reg("last_rejection"), static_cast<int>(last_rejection_));
  set(reg("last_rejection_register"), last_rejection_register_);
  set(reg("trajectory_check"), static_cast<int>(last_check_.fault));
  set(reg("trajectory_check_tick"), last_check_.tick);
  set(reg("trajectory_check_joint"), last_check_.joint + 1);
}

void RegisterBank::refresh_holding() {
  std::uint16_t* hold = mapping_->tab_registers;
  mb::encode(mb::kTrajectory, settings_.trajectory, hold);
  mb::encode(mb::kAmplitudeScale, settings_.scale_permille, hold);
  mb::encode(mb::kRepetitions, settings_.repetitions, hold);
  mb::encode(mb::kLogEnable, settings_.log_enable ? 1 : 0, hold);
  mb::encode(mb::kCommand, 0, hold);
  std::copy(settings_.custom.begin(), settings_.custom.end(), hold + mb::kCustomFirst);
}

bool RegisterBank::refuse(modbus_t* ctx, const std::uint8_t* request, mb::Rejection why,
                          std::uint16_t address, const fw::TrajectoryCheck& check) {
  last_rejection_ = why;
  last_rejection_register_ = address;
  last_check_ = check;
  reply_exception(ctx, request, mb::exception_code(why));
  return false;
}

RegisterBank::Outcome RegisterBank::answer(modbus_t* ctx, const std::uint8_t* request, int length) {
  const int h = modbus_get_header_length(ctx);
  if (length < h + 1) return Outcome::kDrop;  // nothing to answer to
  if (h == 7 && (be16(request + 2) != 0 || be16(request + 4) != length - 6)) return Outcome::kDrop;
  std::lock_guard lock(mutex_);
  return serve(ctx, request, length, h) ? Outcome::kReplied : Outcome::kException;
}

bool RegisterBank::serve(modbus_t* ctx, const std::uint8_t* request, int length, int h) {
  const std::uint8_t function = request[h];
  switch (function) {
    case kReadHolding:
    case kReadInput: {
      if (length < h + 5) return refuse(ctx, request, mb::Rejection::kMalformed, 0);
      const std::uint16_t first = be16(request + h + 1);
      const std::uint16_t count = be16(request + h + 3);
      const unsigned size = function == kReadInput ? mb::kInputCount : mb::kHoldingCount;
      if (count < 1 || count > kMaxReadCount) {
        return refuse(ctx, request, mb::Rejection::kOutOfRange, first);
      }
      if (unsigned{first} + count > size) {
        return refuse(ctx, request, mb::Rejection::kIllegalAddress, first);
      }
      refresh();
      modbus_reply(ctx, request, length, mapping_);
      return true;
    }
    case kWriteSingle: {
      if (length < h + 5) return refuse(ctx, request, mb::Rejection::kMalformed, 0);
      const std::uint16_t value = be16(request + h + 3);
      return write(ctx, request, be16(request + h + 1), &value, 1) &&
             modbus_reply(ctx, request, length, mapping_) >= 0;
    }
    case kWriteMultiple: {
      if (length < h + 6) return refuse(ctx, request, mb::Rejection::kMalformed, 0);
      const std::uint16_t first = be16(request + h + 1);
      const std::uint16_t count = be16(request + h + 3);
      const unsigned bytes = request[h + 5];
      if (count < 1 || count > kMaxWriteCount || bytes != 2u * count ||
          length < h + 6 + static_cast<int>(bytes)) {
        return refuse(ctx, request, mb::Rejection::kMalformed, first);
      }
      std::uint16_t values[kMaxWriteCount];
      for (unsigned i = 0; i < count; ++i) values[i] = be16(request + h + 6 + 2 * i);
      return write(ctx, request, first, values, count) &&
             modbus_reply(ctx, request, length, mapping_) >= 0;
    }
    default:
      return refuse(ctx, request, mb::Rejection::kIllegalFunction, 0);
  }
}

fw::TrajectoryBounds RegisterBank::bounds(const PanelStatus& status) const {
  fw::TrajectoryBounds b = fw::trajectory_bounds(core_);
  b.feed_forward = status.feed_forward;  // the one in use, maybe a model loaded over the bus
  return b;
}

std::optional<fw::CheckedTrajectory> RegisterBank::build(const Settings& s,
                                                         const PanelStatus& status,
                                                         fw::TrajectoryCheck& check) const {
  const std::vector<std::string> names = trajectory_names();
  try {
    const TrajectoryParams params{s.scale_permille, s.repetitions};
    const auto t =
        s.trajectory == static_cast<std::uint16_t>(delta::controller::TrajectoryId::kCustom)
            ? std::optional(custom_trajectory(s.custom.data(), config_, params))
            : named_trajectory(names.at(s.trajectory), config_, params);
    if (!t) throw ConfigError("unknown trajectory");
    fw::CheckedTrajectory c = fw::CheckedTrajectory::check(bounds(status), *t);
    check = c.result();
    if (!c.ok()) return std::nullopt;
    return c;
  } catch (const ConfigError&) {
    check = fw::TrajectoryCheck{fw::TrajectoryFault::kInvalidConfig, 0, -1};
    return std::nullopt;
  }
}

mb::Rejection RegisterBank::take(Settings& next, mb::Command& command, const mb::Register& r,
                                 const std::uint16_t* words, unsigned available) const {
  const unsigned width = mb::width(r.type);
  if (available < width) return mb::Rejection::kIllegalAddress;  // half a 32-bit register
  const std::uint16_t v = words[0];
  bool ok = true;
  if (&r == &mb::kTrajectory) {
    ok = v < trajectory_names().size();
    next.trajectory = v;
  } else if (&r == &mb::kAmplitudeScale) {
    ok = v >= mb::kMinAmplitudeScale && v <= mb::kMaxAmplitudeScale;
    next.scale_permille = v;
  } else if (&r == &mb::kRepetitions) {
    ok = v <= mb::kMaxRepetitions;
    next.repetitions = v;
  } else if (&r == &mb::kLogEnable) {
    ok = v <= 1;
    next.log_enable = v == 1;
  } else if (&r == &mb::kCommand) {
    ok = v <= static_cast<std::uint16_t>(mb::Command::kFaultReset);
    command = static_cast<mb::Command>(v);
  } else {
    // The custom block: ranges of its 16-bit registers; any 32-bit angle.
    if (&r == &mb::kCustomBaseFrequency) ok = v >= 1 && v <= mb::kCustomMaxFrequency_mHz;
    if (&r == &mb::kCustomHarmonics) ok = v <= mb::kCustomMaxHarmonics;
    if (&r == &mb::kCustomPeriods) ok = v >= 1 && v <= mb::kMaxRepetitions;
    if (&r == &mb::kCustomBlend) ok = v >= 1 && v <= mb::kCustomMaxBlend_ms;
    for (unsigned k = 0; k < width; ++k) next.custom[r.address - mb::kCustomFirst + k] = words[k];
  }
  return ok ? mb::Rejection::kNone : mb::Rejection::kOutOfRange;
}

bool RegisterBank::write(modbus_t* ctx, const std::uint8_t* request, std::uint16_t first,
                         const std::uint16_t* values, unsigned count) {
  // Every register must be a holding register, and every value in range,
  // before anything changes.
  Settings next = settings_;
  mb::Command command = mb::Command::kNone;
  std::uint16_t refused_at = 0;
  const mb::Rejection why = take_all(next, command, first, values, count, refused_at);
  if (why != mb::Rejection::kNone) return refuse(ctx, request, why, refused_at);

  // The trajectory's settings do not change while it runs, and a new
  // combination must pass the limits check.
  const PanelStatus status = panel_.status();
  const bool custom =
      next.trajectory == static_cast<std::uint16_t>(delta::controller::TrajectoryId::kCustom);
  const bool custom_changed = next.custom != settings_.custom;
  const bool changed = next.trajectory != settings_.trajectory ||
                       next.scale_permille != settings_.scale_permille ||
                       next.repetitions != settings_.repetitions || (custom && custom_changed);
  if (custom_changed && moving(status)) {
    return refuse(ctx, request, mb::Rejection::kWrongState, first);
  }
  if (changed && moving(status)) {
    return refuse(ctx, request, mb::Rejection::kWrongState, first);
  }
  std::optional<fw::CheckedTrajectory> checked = checked_;
  // Checked again (here, not in the control loop) where the controller's
  // bounds changed since: a model loaded over the bus changes the
  // feed-forward the check covers.
  const bool stale = checked && !checked->checked_against(bounds(status));
  if (changed || (command == mb::Command::kStart && (!checked || stale))) {
    fw::TrajectoryCheck check;
    checked = build(next, status, check);
    if (!checked) return refuse(ctx, request, mb::Rejection::kTrajectoryLimit, first, check);
  }
  settings_ = next;
  checked_ = checked;
  panel_.set_log_enabled(next.log_enable);

  if (command == mb::Command::kNone) return true;
  return submit(ctx, request, command, status);
}

mb::Rejection RegisterBank::take_all(Settings& next, mb::Command& command, std::uint16_t first,
                                     const std::uint16_t* values, unsigned count,
                                     std::uint16_t& refused_at) const {
  for (unsigned i = 0; i < count;) {
    const unsigned a = first + i;
    const mb::Register* r =
        a <= 0xFFFF ? mb::find(mb::Table::kHolding, static_cast<std::uint16_t>(a)) : nullptr;
    refused_at = static_cast<std::uint16_t>(a);
    // Not a register, or the second word of a 32-bit one alone.
    if (r == nullptr) return mb::Rejection::kIllegalAddress;
    const mb::Rejection why = take(next, command, *r, values + i, count - i);
    if (why != mb::Rejection::kNone) return why;
    i += mb::width(r->type);
  }
  return mb::Rejection::kNone;
}

bool RegisterBank::submit(modbus_t* ctx, const std::uint8_t* request, mb::Command command,
                          const PanelStatus& status) {
  if (command == mb::Command::kStart && (status.state != fw::State::kReady || moving(status))) {
    return refuse(ctx, request, mb::Rejection::kWrongState, mb::kCommand.address);
  }
  PanelCommand c;
  c.kind = command;
  if (command == mb::Command::kStart) c.trajectory = checked_;
  c.trajectory_id = settings_.trajectory;
  const auto verdict =
      panel_.submit(std::move(c), std::chrono::milliseconds(config_.modbus.command_timeout_ms));
  if (!verdict) return refuse(ctx, request, mb::Rejection::kNotTaken, mb::kCommand.address);
  if (!verdict->accepted) {
    return refuse(ctx, request, verdict->why, mb::kCommand.address, verdict->check);
  }
  return true;
}

}  // namespace fw_linux
