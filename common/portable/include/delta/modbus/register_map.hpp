// The controller's Modbus register map, defined once: the firmware's server
// (delta_fw), `host_id status` and `host_id excite`, and docs/modbus.md (a
// test checks its tables against this one) all take it from here.
//
// Addresses are the protocol's 0-based addresses. Input registers (function
// 04) are read-only; holding registers (03 read, 06 and 16 write) are the
// settings and the command. A 32-bit value takes two registers, the high
// word first (big-endian word order, as the bytes within a register).
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

#include "delta/controller/vocabulary.hpp"

namespace delta::modbus {

inline constexpr std::uint16_t kMapVersion = 7;  // the input register protocol_version
inline constexpr int kDefaultTcpPort = 1502;     // 502 needs root

enum class Table : std::uint8_t { kInput, kHolding };
enum class Type : std::uint8_t { kU16, kI16, kU32, kI32 };

constexpr unsigned width(Type t) {
  return t == Type::kU32 || t == Type::kI32 ? 2u : 1u;
}

struct Register {
  const char* name;
  Table table;
  std::uint16_t address;
  Type type;
  // value in `unit` = raw * scale_num / scale_den
  std::int32_t scale_num;
  std::int32_t scale_den;
  const char* unit;
  const char* description;
};

// "0 boot, 1 configuring, ...": a register's values and their names, made
// at compile time from a list of names (values 0 to 9), NUL-terminated.
namespace detail {
template <std::size_t N>
constexpr std::size_t enumerated_length(const std::array<std::string_view, N>& names) {
  std::size_t n = 1;  // the NUL
  for (std::size_t i = 0; i < N; ++i) n += (i == 0 ? 0 : 2) + 2 + names[i].size();
  return n;
}
inline constexpr char kNoSuffix[] = "";
// Then `suffix`.
template <const auto& names, const auto& suffix = kNoSuffix>
constexpr auto enumerated_text() {
  static_assert(names.size() <= 10, "one digit per value");
  std::array<char, enumerated_length(names) + sizeof(suffix) - 1> text{};
  std::size_t at = 0;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (i != 0) {
      text[at++] = ',';
      text[at++] = ' ';
    }
    text[at++] = static_cast<char>('0' + i);
    text[at++] = ' ';
    for (char c : names[i]) text[at++] = c;
  }
  for (std::size_t i = 0; i + 1 < sizeof(suffix); ++i) text[at++] = suffix[i];
  return text;
}
}  // namespace detail

// The controller's state (the input register `state`): the values of
// delta::controller::State, with their names.
inline constexpr auto kStateText = detail::enumerated_text<controller::kStateNames>();
// The trajectories (the holding register `trajectory`): only their ids are
// here; the names are the controller's vocabulary.
inline constexpr char kNotWhileRunning[] = "; not while running";
inline constexpr auto kTrajectoryText =
    detail::enumerated_text<controller::kTrajectoryNames, kNotWhileRunning>();

// Run results (the input register `run_result`).
enum class RunResult : std::uint16_t {
  kNone = 0,      // no run started yet
  kRunning = 1,   // the run is in progress (approach, trajectory or stopping)
  kFinished = 2,  // it ran to its end and the controller is ready again
  kStopped = 3,   // a stop command ended it early
  kFaulted = 4,   // a fault ended it (fault_code says which)
};

// Commands (the holding register `command`).
enum class Command : std::uint16_t { kNone = 0, kStart = 1, kStop = 2, kFaultReset = 3 };

// Why the last write was refused (the input register `last_rejection`).
enum class Rejection : std::uint16_t {
  kNone = 0,
  kIllegalAddress = 1,   // not a holding register (exception 02)
  kOutOfRange = 2,       // a value outside the register's range (exception 03)
  kWrongState = 3,       // not allowed in the controller's state (exception 06)
  kEStopOpen = 4,        // a fault reset while the e-stop is open (exception 06)
  kTrajectoryLimit = 5,  // the trajectory with these settings breaks a limit (exception 03)
  kMalformed = 6,        // a request the server could not parse (exception 03)
  kIllegalFunction = 7,  // a function code the server does not serve (exception 01)
  kNotTaken = 8,         // the control loop did not take the command in time (exception 06)
};

// The Modbus exception code each rejection is answered with.
constexpr std::uint8_t exception_code(Rejection r) {
  switch (r) {
    case Rejection::kIllegalFunction:
      return 0x01;
    case Rejection::kIllegalAddress:
      return 0x02;
    case Rejection::kOutOfRange:
    case Rejection::kTrajectoryLimit:
    case Rejection::kMalformed:
      return 0x03;
    case Rejection::kWrongState:
    case Rejection::kEStopOpen:
    case Rejection::kNotTaken:
      return 0x06;
    case Rejection::kNone:
      break;
  }
  return 0x04;
}

// A sentence for a rejection, for messages.
constexpr const char* describe(Rejection r) {
  switch (r) {
    case Rejection::kNone:
      return "none";
    case Rejection::kIllegalAddress:
      return "not a holding register";
    case Rejection::kOutOfRange:
      return "value out of range";
    case Rejection::kWrongState:
      return "not allowed in the controller's state";
    case Rejection::kEStopOpen:
      return "the e-stop is open";
    case Rejection::kTrajectoryLimit:
      return "the trajectory with these settings breaks a limit";
    case Rejection::kMalformed:
      return "malformed request";
    case Rejection::kIllegalFunction:
      return "function code not served";
    case Rejection::kNotTaken:
      return "the control loop did not take the command in time";
  }
  return "unknown";
}

// Bits of the input register `io`.
inline constexpr std::uint16_t kIoEStopOpen = 1u << 0;
inline constexpr std::uint16_t kIoDriveEnable = 1u << 1;
inline constexpr std::uint16_t kIoBrakeReleased = 1u << 2;
inline constexpr std::uint16_t kIoStatusOk = 1u << 3;
inline constexpr std::uint16_t kIoLogEnabled = 1u << 4;

inline constexpr unsigned kFaultHistoryLength = 8;

// clang-format off
inline constexpr std::array<Register, 117> kRegisters{{
    // Identity
    {"firmware_version_major", Table::kInput, 0, Type::kU16, 1, 1, "", "firmware version, major"},
    {"firmware_version_minor", Table::kInput, 1, Type::kU16, 1, 1, "", "firmware version, minor"},
    {"firmware_version_patch", Table::kInput, 2, Type::kU16, 1, 1, "", "firmware version, patch"},
    {"protocol_version", Table::kInput, 3, Type::kU16, 1, 1, "", "version of this register map (7)"},
    // State
    {"state", Table::kInput, 4, Type::kU16, 1, 1, "", kStateText.data()},
    {"fault_code", Table::kInput, 5, Type::kU16, 1, 1, "", "the current fault (docs/firmware.md), 0 none"},
    {"cycle_counter", Table::kInput, 6, Type::kU32, 1, 1, "", "control cycles since start"},
    {"period_us", Table::kInput, 8, Type::kU32, 1, 1, "us", "control cycle period"},
    {"io", Table::kInput, 10, Type::kU16, 1, 1, "", "bit 0 e-stop open, 1 drive enable, 2 brake released, 3 status ok, 4 log enabled"},
    // The run
    {"run_id", Table::kInput, 11, Type::kU16, 1, 1, "", "counts accepted start commands (wraps at 65536)"},
    {"run_result", Table::kInput, 12, Type::kU16, 1, 1, "", "of run run_id: 0 none, 1 running, 2 finished, 3 stopped, 4 faulted"},
    {"run_tick", Table::kInput, 13, Type::kU32, 1, 1, "", "cycles into the run"},
    {"run_length", Table::kInput, 15, Type::kU32, 1, 1, "", "cycles the run takes (approach, trajectory)"},
    {"log_records", Table::kInput, 17, Type::kU32, 1, 1, "", "log records sent since start (the log frames' seq, unwrapped)"},
    // Faults
    {"fault_count", Table::kInput, 19, Type::kU16, 1, 1, "", "faults since start"},
    {"fault_history_0_code", Table::kInput, 20, Type::kU16, 1, 1, "", "newest fault: code, 0 none"},
    {"fault_history_0_cycle", Table::kInput, 21, Type::kU32, 1, 1, "", "newest fault: the cycle it happened in"},
    {"fault_history_1_code", Table::kInput, 23, Type::kU16, 1, 1, "", "fault 1 before the newest: code, 0 none"},
    {"fault_history_1_cycle", Table::kInput, 24, Type::kU32, 1, 1, "", "fault 1 before the newest: the cycle it happened in"},
    {"fault_history_2_code", Table::kInput, 26, Type::kU16, 1, 1, "", "fault 2 before the newest: code, 0 none"},
    {"fault_history_2_cycle", Table::kInput, 27, Type::kU32, 1, 1, "", "fault 2 before the newest: the cycle it happened in"},
    {"fault_history_3_code", Table::kInput, 29, Type::kU16, 1, 1, "", "fault 3 before the newest: code, 0 none"},
    {"fault_history_3_cycle", Table::kInput, 30, Type::kU32, 1, 1, "", "fault 3 before the newest: the cycle it happened in"},
    {"fault_history_4_code", Table::kInput, 32, Type::kU16, 1, 1, "", "fault 4 before the newest: code, 0 none"},
    {"fault_history_4_cycle", Table::kInput, 33, Type::kU32, 1, 1, "", "fault 4 before the newest: the cycle it happened in"},
    {"fault_history_5_code", Table::kInput, 35, Type::kU16, 1, 1, "", "fault 5 before the newest: code, 0 none"},
    {"fault_history_5_cycle", Table::kInput, 36, Type::kU32, 1, 1, "", "fault 5 before the newest: the cycle it happened in"},
    {"fault_history_6_code", Table::kInput, 38, Type::kU16, 1, 1, "", "fault 6 before the newest: code, 0 none"},
    {"fault_history_6_cycle", Table::kInput, 39, Type::kU32, 1, 1, "", "fault 6 before the newest: the cycle it happened in"},
    {"fault_history_7_code", Table::kInput, 41, Type::kU16, 1, 1, "", "fault 7 before the newest: code, 0 none"},
    {"fault_history_7_cycle", Table::kInput, 42, Type::kU32, 1, 1, "", "fault 7 before the newest: the cycle it happened in"},
    {"last_rejection", Table::kInput, 44, Type::kU16, 1, 1, "", "why the last refused request was refused (docs/modbus.md), 0 none"},
    {"last_rejection_register", Table::kInput, 45, Type::kU16, 1, 1, "", "the holding register it wrote"},
    {"trajectory_check", Table::kInput, 46, Type::kU16, 1, 1, "", "on rejection 5: 1 invalid, 2 joint limit, 3 velocity, 4 acceleration, 5 workspace, 6 too long, 7 feed-forward over the max torque"},
    {"trajectory_check_tick", Table::kInput, 47, Type::kU32, 1, 1, "", "on rejection 5: the first tick that breaks it"},
    {"trajectory_check_joint", Table::kInput, 49, Type::kU16, 1, 1, "", "on rejection 5: the joint (1-3), 0 none"},
    // Geometry read-back
    {"upper_arm_length", Table::kInput, 50, Type::kU32, 1, 1000000, "m", "upper arm length (um)"},
    {"forearm_length", Table::kInput, 52, Type::kU32, 1, 1000000, "m", "forearm length (um)"},
    {"base_radius", Table::kInput, 54, Type::kU32, 1, 1000000, "m", "base radius (um)"},
    {"platform_radius", Table::kInput, 56, Type::kU32, 1, 1000000, "m", "platform radius (um)"},
    // Live values, from the last cycle
    {"q1", Table::kInput, 60, Type::kI32, 1, 1000000, "rad", "joint 1 angle (urad)"},
    {"q2", Table::kInput, 62, Type::kI32, 1, 1000000, "rad", "joint 2 angle (urad)"},
    {"q3", Table::kInput, 64, Type::kI32, 1, 1000000, "rad", "joint 3 angle (urad)"},
    {"tau1", Table::kInput, 66, Type::kI32, 1, 1000000, "N m", "joint 1 torque from current (uN m)"},
    {"tau2", Table::kInput, 68, Type::kI32, 1, 1000000, "N m", "joint 2 torque from current (uN m)"},
    {"tau3", Table::kInput, 70, Type::kI32, 1, 1000000, "N m", "joint 3 torque from current (uN m)"},
    {"trajectory_count", Table::kInput, 72, Type::kU16, 1, 1, "", "trajectories the controller knows (ids 0 .. count-1)"},
    {"stale_log_records", Table::kInput, 73, Type::kU32, 1, 1, "", "of log_records, those marked stale (a drive's feedback missed the cycle)"},
    {"update_rollback", Table::kInput, 75, Type::kU16, 1, 1, "", "why delta_boot rolled a new program back before this one started (docs/flashing.md): 0 none, 1 no confirmation in time, 2 exited, 3 crashed, 4 power lost during the trial, 5 could not start"},
    // The tracking error of run tracking_run_id's trajectory (after the approach)
    {"tracking_run_id", Table::kInput, 76, Type::kU16, 1, 1, "", "the run the tracking registers are of (run_id when it ran), 0 none yet"},
    {"tracking_ticks", Table::kInput, 77, Type::kU32, 1, 1, "", "the trajectory's cycles they cover"},
    {"tracking_rms_1", Table::kInput, 79, Type::kU32, 1, 1000000000, "rad", "joint 1 RMS of q_ref - q (nrad)"},
    {"tracking_rms_2", Table::kInput, 81, Type::kU32, 1, 1000000000, "rad", "joint 2 RMS of q_ref - q (nrad)"},
    {"tracking_rms_3", Table::kInput, 83, Type::kU32, 1, 1000000000, "rad", "joint 3 RMS of q_ref - q (nrad)"},
    {"tracking_max_1", Table::kInput, 85, Type::kU32, 1, 1000000000, "rad", "joint 1 largest abs(q_ref - q) (nrad)"},
    {"tracking_max_2", Table::kInput, 87, Type::kU32, 1, 1000000000, "rad", "joint 2 largest abs(q_ref - q) (nrad)"},
    {"tracking_max_3", Table::kInput, 89, Type::kU32, 1, 1000000000, "rad", "joint 3 largest abs(q_ref - q) (nrad)"},
    // The feed-forward in use (docs/protocol.md, node 16's 0x2200)
    {"feed_forward_mode", Table::kInput, 91, Type::kU16, 1, 1, "", "0 off, 1 nominal, 2 the identified model"},
    {"model_fit_id", Table::kInput, 92, Type::kU32, 1, 1, "", "the fit id of the model loaded or configured (CRC-32 of its result file), 0 none"},
    // The collision detector (docs/safety.md) and its last detection
    {"collision_detect", Table::kInput, 94, Type::kU16, 1, 1, "", "1 the detector is on, 0 off"},
    {"collision_count", Table::kInput, 95, Type::kU16, 1, 1, "", "detections since start"},
    {"collision_joint", Table::kInput, 96, Type::kU16, 1, 1, "", "the last detection's joint (1-3), 0 none yet"},
    {"collision_t", Table::kInput, 97, Type::kU32, 1, 1000, "s", "its time since the first SYNC (ms)"},
    {"collision_residual_1", Table::kInput, 99, Type::kI32, 1, 1000000, "N m", "its joint 1 filtered residual (uN m)"},
    {"collision_residual_2", Table::kInput, 101, Type::kI32, 1, 1000000, "N m", "its joint 2 filtered residual (uN m)"},
    {"collision_residual_3", Table::kInput, 103, Type::kI32, 1, 1000000, "N m", "its joint 3 filtered residual (uN m)"},
    {"collision_threshold_1", Table::kInput, 105, Type::kI32, 1, 1000000, "N m", "its joint 1 threshold (uN m)"},
    {"collision_threshold_2", Table::kInput, 107, Type::kI32, 1, 1000000, "N m", "its joint 2 threshold (uN m)"},
    {"collision_threshold_3", Table::kInput, 109, Type::kI32, 1, 1000000, "N m", "its joint 3 threshold (uN m)"},
    // Settings and the command
    {"trajectory", Table::kHolding, 0, Type::kU16, 1, 1, "", kTrajectoryText.data()},
    {"amplitude_scale", Table::kHolding, 1, Type::kU16, 1, 1000, "", "1-2000 per mille of the trajectory's amplitude; not while running"},
    {"repetitions", Table::kHolding, 2, Type::kU16, 1, 1, "", "0-100 Fourier periods or pick-and-place cycles, 0 the preset's (2 or 3); not while running"},
    {"log_enable", Table::kHolding, 3, Type::kU16, 1, 1, "", "1: send the log frames while running, 0: not"},
    {"command", Table::kHolding, 4, Type::kU16, 1, 1, "", "write 1 start (ready only), 2 stop, 3 fault reset; reads 0"},
    // The custom Fourier trajectory (trajectory 3), docs/modbus.md
    {"custom_base_frequency", Table::kHolding, 10, Type::kU16, 1, 1000, "Hz", "custom trajectory: base frequency (mHz), 1-5000; not while running"},
    {"custom_harmonics", Table::kHolding, 11, Type::kU16, 1, 1, "", "custom trajectory: harmonics, 1-6 (0: none uploaded); not while running"},
    {"custom_periods", Table::kHolding, 12, Type::kU16, 1, 1, "", "custom trajectory: whole periods, 1-100; not while running"},
    {"custom_blend", Table::kHolding, 13, Type::kU16, 1, 1000, "s", "custom trajectory: fade in and out (ms), 1-60000; not while running"},
    {"custom_q0_1", Table::kHolding, 14, Type::kI32, 1, 1000000000, "rad", "custom trajectory: q0 of joint 1 (nrad); not while running"},
    {"custom_q0_2", Table::kHolding, 16, Type::kI32, 1, 1000000000, "rad", "custom trajectory: q0 of joint 2 (nrad); not while running"},
    {"custom_q0_3", Table::kHolding, 18, Type::kI32, 1, 1000000000, "rad", "custom trajectory: q0 of joint 3 (nrad); not while running"},
    {"custom_sin_1_1", Table::kHolding, 20, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 1, k = 1 (nrad); not while running"},
    {"custom_sin_1_2", Table::kHolding, 22, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 1, k = 2 (nrad); not while running"},
    {"custom_sin_1_3", Table::kHolding, 24, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 1, k = 3 (nrad); not while running"},
    {"custom_sin_1_4", Table::kHolding, 26, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 1, k = 4 (nrad); not while running"},
    {"custom_sin_1_5", Table::kHolding, 28, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 1, k = 5 (nrad); not while running"},
    {"custom_sin_1_6", Table::kHolding, 30, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 1, k = 6 (nrad); not while running"},
    {"custom_sin_2_1", Table::kHolding, 32, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 2, k = 1 (nrad); not while running"},
    {"custom_sin_2_2", Table::kHolding, 34, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 2, k = 2 (nrad); not while running"},
    {"custom_sin_2_3", Table::kHolding, 36, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 2, k = 3 (nrad); not while running"},
    {"custom_sin_2_4", Table::kHolding, 38, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 2, k = 4 (nrad); not while running"},
    {"custom_sin_2_5", Table::kHolding, 40, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 2, k = 5 (nrad); not while running"},
    {"custom_sin_2_6", Table::kHolding, 42, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 2, k = 6 (nrad); not while running"},
    {"custom_sin_3_1", Table::kHolding, 44, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 3, k = 1 (nrad); not while running"},
    {"custom_sin_3_2", Table::kHolding, 46, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 3, k = 2 (nrad); not while running"},
    {"custom_sin_3_3", Table::kHolding, 48, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 3, k = 3 (nrad); not while running"},
    {"custom_sin_3_4", Table::kHolding, 50, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 3, k = 4 (nrad); not while running"},
    {"custom_sin_3_5", Table::kHolding, 52, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 3, k = 5 (nrad); not while running"},
    {"custom_sin_3_6", Table::kHolding, 54, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude A, of sin(k w t), joint 3, k = 6 (nrad); not while running"},
    {"custom_cos_1_1", Table::kHolding, 56, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 1, k = 1 (nrad); not while running"},
    {"custom_cos_1_2", Table::kHolding, 58, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 1, k = 2 (nrad); not while running"},
    {"custom_cos_1_3", Table::kHolding, 60, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 1, k = 3 (nrad); not while running"},
    {"custom_cos_1_4", Table::kHolding, 62, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 1, k = 4 (nrad); not while running"},
    {"custom_cos_1_5", Table::kHolding, 64, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 1, k = 5 (nrad); not while running"},
    {"custom_cos_1_6", Table::kHolding, 66, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 1, k = 6 (nrad); not while running"},
    {"custom_cos_2_1", Table::kHolding, 68, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 2, k = 1 (nrad); not while running"},
    {"custom_cos_2_2", Table::kHolding, 70, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 2, k = 2 (nrad); not while running"},
    {"custom_cos_2_3", Table::kHolding, 72, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 2, k = 3 (nrad); not while running"},
    {"custom_cos_2_4", Table::kHolding, 74, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 2, k = 4 (nrad); not while running"},
    {"custom_cos_2_5", Table::kHolding, 76, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 2, k = 5 (nrad); not while running"},
    {"custom_cos_2_6", Table::kHolding, 78, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 2, k = 6 (nrad); not while running"},
    {"custom_cos_3_1", Table::kHolding, 80, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 3, k = 1 (nrad); not while running"},
    {"custom_cos_3_2", Table::kHolding, 82, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 3, k = 2 (nrad); not while running"},
    {"custom_cos_3_3", Table::kHolding, 84, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 3, k = 3 (nrad); not while running"},
    {"custom_cos_3_4", Table::kHolding, 86, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 3, k = 4 (nrad); not while running"},
    {"custom_cos_3_5", Table::kHolding, 88, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 3, k = 5 (nrad); not while running"},
    {"custom_cos_3_6", Table::kHolding, 90, Type::kI32, 1, 1000000000, "rad", "custom trajectory: amplitude B, of cos(k w t), joint 3, k = 6 (nrad); not while running"},
}};
// clang-format on

// The register named `name`; a name not in the table does not compile
// (the reference past the end is not a constant expression).
constexpr const Register& named(std::string_view name) {
  for (const Register& r : kRegisters) {
    if (name == r.name) return r;
  }
  return kRegisters.data()[kRegisters.size()];
}

// The register at `address` of `table`, or nullptr (the second word of a
// 32-bit value is not a register of its own).
constexpr const Register* find(Table table, std::uint16_t address) {
  for (const Register& r : kRegisters) {
    if (r.table == table && r.address == address) return &r;
  }
  return nullptr;
}

// The extent of each table: every register lies below these.
constexpr std::uint16_t table_size(Table table) {
  unsigned end = 0;
  for (const Register& r : kRegisters) {
    if (r.table == table && r.address + width(r.type) > end) end = r.address + width(r.type);
  }
  return static_cast<std::uint16_t>(end);
}

// A value in a register block: `regs` holds the table from address 0.
constexpr std::int64_t decode(const Register& r, const std::uint16_t* regs) {
  const std::uint16_t hi = regs[r.address];
  switch (r.type) {
    case Type::kU16:
      return hi;
    case Type::kI16:
      return static_cast<std::int16_t>(hi);
    case Type::kU32:
      return (std::uint32_t{hi} << 16) | regs[r.address + 1];
    case Type::kI32:
      return static_cast<std::int32_t>((std::uint32_t{hi} << 16) | regs[r.address + 1]);
  }
  return 0;
}

// Stores `value` (already in the register's raw integer form, truncated to
// its width) into a register block.
constexpr void encode(const Register& r, std::int64_t value, std::uint16_t* regs) {
  const auto v = static_cast<std::uint32_t>(value);
  if (width(r.type) == 2) {
    regs[r.address] = static_cast<std::uint16_t>(v >> 16);
    regs[r.address + 1] = static_cast<std::uint16_t>(v & 0xFFFFu);
  } else {
    regs[r.address] = static_cast<std::uint16_t>(v & 0xFFFFu);
  }
}

// Entry k (0 = newest) of the fault history: its registers follow the
// first entry's every 3 addresses (code, then the 32-bit cycle).
constexpr const Register& fault_history_code(unsigned k) {
  return *find(Table::kInput,
               static_cast<std::uint16_t>(named("fault_history_0_code").address + 3 * k));
}
constexpr const Register& fault_history_cycle(unsigned k) {
  return *find(Table::kInput,
               static_cast<std::uint16_t>(named("fault_history_0_cycle").address + 3 * k));
}
static_assert(fault_history_code(kFaultHistoryLength - 1).type == Type::kU16);
static_assert(fault_history_cycle(kFaultHistoryLength - 1).type == Type::kU32);

inline constexpr std::uint16_t kInputCount = table_size(Table::kInput);
inline constexpr std::uint16_t kHoldingCount = table_size(Table::kHolding);

// The holding registers by name.
inline constexpr const Register& kTrajectory = named("trajectory");
inline constexpr const Register& kAmplitudeScale = named("amplitude_scale");
inline constexpr const Register& kRepetitions = named("repetitions");
inline constexpr const Register& kLogEnable = named("log_enable");
inline constexpr const Register& kCommand = named("command");

inline constexpr std::uint16_t kMinAmplitudeScale = 1;
inline constexpr std::uint16_t kMaxAmplitudeScale = 2000;
inline constexpr std::uint16_t kMaxRepetitions = 100;

// The custom Fourier trajectory's block (trajectory 3): its frequency,
// harmonics, periods and blend, then q0 and the amplitudes A (sin) and B
// (cos) of each joint and harmonic, 32-bit in nrad.
inline constexpr const Register& kCustomBaseFrequency = named("custom_base_frequency");
inline constexpr const Register& kCustomHarmonics = named("custom_harmonics");
inline constexpr const Register& kCustomPeriods = named("custom_periods");
inline constexpr const Register& kCustomBlend = named("custom_blend");
inline constexpr unsigned kCustomMaxHarmonics = 6;
constexpr const Register& custom_q0(unsigned joint) {
  return *find(Table::kHolding,
               static_cast<std::uint16_t>(named("custom_q0_1").address + 2 * joint));
}
constexpr const Register& custom_sin(unsigned joint, unsigned harmonic) {
  return *find(Table::kHolding,
               static_cast<std::uint16_t>(named("custom_sin_1_1").address +
                                          2 * (kCustomMaxHarmonics * joint + harmonic)));
}
constexpr const Register& custom_cos(unsigned joint, unsigned harmonic) {
  return *find(Table::kHolding,
               static_cast<std::uint16_t>(named("custom_cos_1_1").address +
                                          2 * (kCustomMaxHarmonics * joint + harmonic)));
}
static_assert(&custom_sin(2, 5) == &named("custom_sin_3_6"));
static_assert(&custom_cos(2, 5) == &named("custom_cos_3_6"));
static_assert(&custom_q0(2) == &named("custom_q0_3"));
// The block's extent: one write multiple (16) carries all of it.
inline constexpr std::uint16_t kCustomFirst = named("custom_base_frequency").address;
inline constexpr std::uint16_t kCustomCount =
    static_cast<std::uint16_t>(named("custom_cos_3_6").address + 2 - kCustomFirst);
inline constexpr std::uint16_t kCustomMaxFrequency_mHz = 5000;
inline constexpr std::uint16_t kCustomMaxBlend_ms = 60000;

}  // namespace delta::modbus
