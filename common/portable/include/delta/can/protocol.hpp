// The CAN protocol, defined once: every message's ID, layout and scaling.
// The firmware, the emulator, `host_id record` and the DBC file
// (docs/delta.dbc, written by `host_id dbc`) all take them from this table.
// Integer only (scalings are rationals times powers of two), no heap: it
// serves the firmware core as well as the host.
//
// CANopen (CiA 301) predefined connection set; the three drives are nodes
// 1..3 (CiA 402 drive profile), the controller is node 16.
#pragma once

#include <array>
#include <cstdint>
#include <string_view>

namespace delta::can::protocol {

inline constexpr std::uint8_t kControllerNode = 16;
// The controller's identity (0x1018:1, 0x1018:2), which firmware images
// name (docs/flashing.md): the product's vendor ID (not one CiA assigned)
// and the product code of delta_fw.
inline constexpr std::uint32_t kControllerVendorId = 0x0000DE17;
inline constexpr std::uint32_t kControllerProductCode = 0x00000016;
inline constexpr std::uint8_t kFirstDriveNode = 1;
inline constexpr std::uint8_t kDriveCount = 3;

// value = raw * numerator / denominator * 2^power2, in `unit`.
struct Scale {
  std::int32_t numerator{1};
  std::int32_t denominator{1};
  std::int8_t power2{0};
};

struct Signal {
  const char* name;
  std::uint8_t start_bit;  // little endian (Intel), bit 0 = LSB of byte 0
  std::uint8_t length;     // bits
  bool is_signed;
  Scale scale;
  const char* unit;
  const char* comment;
};

enum class Sender : std::uint8_t { kController, kDrive };
// Who consumes a message besides the recorder, which listens to everything.
enum class Receiver : std::uint8_t { kDrives, kController, kRecorderOnly };

struct Message {
  const char* name;
  std::uint16_t base_id;  // 11-bit COB-ID; + node ID when per_node
  bool per_node;          // one message per drive (or for the controller, node 16)
  std::uint8_t dlc;
  Sender sender;
  Receiver receiver;
  std::uint8_t signal_count;
  std::array<Signal, 5> signals;
  const char* comment;
};

// Scalings used below.
inline constexpr Scale kRaw{1, 1, 0};
inline constexpr Scale kPerMille{1, 1000, 0};  // of the drive's rated value
inline constexpr Scale kLogAngle{1, 1, -20};   // 2^-20 rad (9.5e-7 rad), +/- 8 rad
inline constexpr Scale kLogTorque{1, 1, -16};  // 2^-16 N m (1.5e-5 N m), +/- 128 N m

inline constexpr std::array<Message, 19> kMessages{{
    {"NMT",
     0x000,
     false,
     2,
     Sender::kController,
     Receiver::kDrives,
     2,
     {{{"command", 0, 8, false, kRaw, "",
        "1 start, 2 stop, 128 pre-operational, 129 reset node, 130 reset communication"},
       {"node", 8, 8, false, kRaw, "", "target node, 0 = all"}}},
     "network management"},
    {"SYNC",
     0x080,
     false,
     0,
     Sender::kController,
     Receiver::kDrives,
     0,
     {},
     "starts a control cycle; drives answer with TPDOs. With sync_counter_overflow > 0 "
     "(0x1019) it has 1 byte, the SYNC counter (kSyncCounter)"},
    {"EMCY",
     0x080,
     true,
     8,
     Sender::kDrive,
     Receiver::kController,
     3,
     {{{"error_code", 0, 16, false, kRaw, "", "CiA 301/402 emergency error code"},
       {"error_register", 16, 8, false, kRaw, "", "object 0x1001"},
       {"vendor", 24, 40, false, kRaw, "", "manufacturer-specific"}}},
     "emergency from a drive"},
    {"TPDO1",
     0x180,
     true,
     8,
     Sender::kDrive,
     Receiver::kController,
     3,
     {{{"statusword", 0, 16, false, kRaw, "", "CiA 402 object 0x6041"},
       {"position_actual", 16, 32, true, kRaw, "counts",
        "object 0x6064, encoder counts at the motor"},
       {"current_actual", 48, 16, true, kPerMille, "rated current", "object 0x6078"}}},
     "drive feedback on SYNC"},
    {"TPDO2",
     0x280,
     true,
     4,
     Sender::kDrive,
     Receiver::kController,
     1,
     {{{"velocity_actual", 0, 32, true, kRaw, "counts/s", "object 0x606C"}}},
     "drive velocity on SYNC"},
    {"RPDO1",
     0x200,
     true,
     8,
     Sender::kController,
     Receiver::kDrives,
     3,
     {{{"controlword", 0, 16, false, kRaw, "", "CiA 402 object 0x6040"},
       {"target_torque", 16, 16, true, kPerMille, "rated torque",
        "object 0x6071 (cyclic synchronous torque)"},
       {"target_position", 32, 32, true, kRaw, "counts",
        "object 0x607A: the arm reference during a run, else the drive position"}}},
     "drive command, applied on the next SYNC"},
    {"SDO_RX",
     0x600,
     true,
     8,
     Sender::kController,
     Receiver::kDrives,
     4,
     {{{"command", 0, 8, false, kRaw, "", "SDO command specifier"},
       {"index", 8, 16, false, kRaw, "", "object index"},
       {"subindex", 24, 8, false, kRaw, "", "object sub-index"},
       {"data", 32, 32, false, kRaw, "", "expedited data or abort code"}}},
     "SDO request to a drive"},
    {"SDO_TX",
     0x580,
     true,
     8,
     Sender::kDrive,
     Receiver::kController,
     4,
     {{{"command", 0, 8, false, kRaw, "", "SDO command specifier"},
       {"index", 8, 16, false, kRaw, "", "object index"},
       {"subindex", 24, 8, false, kRaw, "", "object sub-index"},
       {"data", 32, 32, false, kRaw, "", "expedited data or abort code"}}},
     "SDO response from a drive"},
    {"HEARTBEAT",
     0x700,
     true,
     1,
     Sender::kDrive,
     Receiver::kController,
     1,
     {{{"nmt_state", 0, 8, false, kRaw, "",
        "0 boot-up, 4 stopped, 5 operational, 127 pre-operational"}}},
     "heartbeat of a drive"},
    {"LOG_A",
     0x190,
     false,
     8,
     Sender::kController,
     Receiver::kRecorderOnly,
     4,
     {{{"seq", 0, 15, false, kRaw, "", "log sample counter, modulo 32768"},
       {"q1", 16, 24, true, kLogAngle, "rad", "joint 1 angle"},
       {"q2", 40, 24, true, kLogAngle, "rad", "joint 2 angle"},
       {"stale", 15, 1, false, kRaw, "",
        "1: a drive's feedback missed this cycle, so q and tau are not a sample"}}},
     "controller log, part 1 of 3 (TPDO1 of node 16)"},
    {"LOG_B",
     0x290,
     false,
     8,
     Sender::kController,
     Receiver::kRecorderOnly,
     4,
     {{{"seq", 0, 15, false, kRaw, "", "log sample counter, modulo 32768"},
       {"q3", 16, 24, true, kLogAngle, "rad", "joint 3 angle"},
       {"tau1", 40, 24, true, kLogTorque, "N m", "joint 1 torque from current"},
       {"stale", 15, 1, false, kRaw, "",
        "1: a drive's feedback missed this cycle, so q and tau are not a sample"}}},
     "controller log, part 2 of 3 (TPDO2 of node 16)"},
    {"LOG_C",
     0x390,
     false,
     8,
     Sender::kController,
     Receiver::kRecorderOnly,
     4,
     {{{"seq", 0, 15, false, kRaw, "", "log sample counter, modulo 32768"},
       {"tau2", 16, 24, true, kLogTorque, "N m", "joint 2 torque from current"},
       {"tau3", 40, 24, true, kLogTorque, "N m", "joint 3 torque from current"},
       {"stale", 15, 1, false, kRaw, "",
        "1: a drive's feedback missed this cycle, so q and tau are not a sample"}}},
     "controller log, part 3 of 3 (TPDO3 of node 16)"},
    {"CONTROLLER_EMCY",
     0x090,
     false,
     8,
     Sender::kController,
     Receiver::kRecorderOnly,
     4,
     {{{"error_code", 0, 16, false, kRaw, "",
        "0xFF00 + fault code on a fault, 0x0000 when the fault is reset, 0x6200 after a "
        "roll-back"},
       {"error_register", 16, 8, false, kRaw, "", "1 while in fault or on a roll-back"},
       {"fault_code", 24, 8, false, kRaw, "",
        "the firmware's fault code (docs/firmware.md); with 0x6200 why delta_boot rolled the "
        "new program back (docs/flashing.md)"},
       {"cycle", 32, 32, false, kRaw, "", "the controller's cycle counter at the fault"}}},
     "emergency of the controller (EMCY of node 16)"},
    {"CONTROLLER_HEARTBEAT",
     0x710,
     false,
     1,
     Sender::kController,
     Receiver::kDrives,
     1,
     {{{"nmt_state", 0, 8, false, kRaw, "", "5 operational"}}},
     "heartbeat of the controller (node 16)"},
    {"TPDO3",
     0x380,
     true,
     1,
     Sender::kDrive,
     Receiver::kController,
     1,
     {{{"sync_counter", 0, 8, false, kRaw, "",
        "object 0x2019: the counter of the SYNC this cycle's TPDOs answer"}}},
     "the cycle of the drive's sample, sent after its TPDO1 and TPDO2; only with "
     "sync_counter_overflow > 0"},
    {"COLLISION",
     0x490,
     false,
     8,
     Sender::kController,
     Receiver::kRecorderOnly,
     4,
     {{{"joint", 0, 8, false, kRaw, "", "1-3: the joint whose residual and threshold follow"},
       {"tripped", 8, 8, false, kRaw, "", "1-3: the joint over its threshold"},
       {"residual", 16, 24, true, kLogTorque, "N m", "the joint's filtered torque residual"},
       {"threshold", 40, 24, false, kLogTorque, "N m", "the joint's threshold at that tick"}}},
     "a collision detected (TPDO4 of node 16, 0x1803/0x1A03 onto 0x2103): three frames, "
     "joints 1, 2, 3, right after the EMCY of fault 14"},
    {"TPDO4",
     0x480,
     true,
     4,
     Sender::kDrive,
     Receiver::kController,
     1,
     {{{"arm_position_actual", 0, 32, true, kRaw, "counts",
        "object 0x60E4:1, the arm-side encoder in 0x6064's position units"}}},
     "the arm-side encoder on SYNC; only with arm_encoders = true"},
    {"LOG_D",
     0x1D0,
     false,
     8,
     Sender::kController,
     Receiver::kRecorderOnly,
     4,
     {{{"seq", 0, 15, false, kRaw, "", "log sample counter, modulo 32768"},
       {"qa1", 16, 24, true, kLogAngle, "rad", "joint 1 arm angle (arm-side encoder)"},
       {"qa2", 40, 24, true, kLogAngle, "rad", "joint 2 arm angle (arm-side encoder)"},
       {"stale", 15, 1, false, kRaw, "",
        "1: a drive's feedback missed this cycle, so qa is not a sample"}}},
     "controller log of the arm-side encoders, part 1 of 2 (TPDO5 of node 16); only with "
     "arm_encoders = true"},
    {"LOG_E",
     0x2D0,
     false,
     5,
     Sender::kController,
     Receiver::kRecorderOnly,
     3,
     {{{"seq", 0, 15, false, kRaw, "", "log sample counter, modulo 32768"},
       {"qa3", 16, 24, true, kLogAngle, "rad", "joint 3 arm angle (arm-side encoder)"},
       {"stale", 15, 1, false, kRaw, "",
        "1: a drive's feedback missed this cycle, so qa is not a sample"}}},
     "controller log of the arm-side encoders, part 2 of 2 (TPDO6 of node 16); only with "
     "arm_encoders = true"},
}};

// The messages by name.
inline constexpr const Message& kNmt = kMessages[0];
inline constexpr const Message& kSync = kMessages[1];
inline constexpr const Message& kEmcy = kMessages[2];
inline constexpr const Message& kTpdo1 = kMessages[3];
inline constexpr const Message& kTpdo2 = kMessages[4];
inline constexpr const Message& kRpdo1 = kMessages[5];
inline constexpr const Message& kSdoRx = kMessages[6];
inline constexpr const Message& kSdoTx = kMessages[7];
inline constexpr const Message& kHeartbeat = kMessages[8];
inline constexpr const Message& kLogA = kMessages[9];
inline constexpr const Message& kLogB = kMessages[10];
inline constexpr const Message& kLogC = kMessages[11];
inline constexpr const Message& kControllerEmcy = kMessages[12];
inline constexpr const Message& kControllerHeartbeat = kMessages[13];
inline constexpr const Message& kTpdo3 = kMessages[14];
inline constexpr const Message& kCollision = kMessages[15];
inline constexpr const Message& kTpdo4 = kMessages[16];
inline constexpr const Message& kLogD = kMessages[17];
inline constexpr const Message& kLogE = kMessages[18];

// The signals by name: a wrong name does not compile.
namespace detail {
void no_such_signal();  // not constexpr, so a call in a constant expression fails
}  // namespace detail
consteval const Signal& signal_named(const Message& m, std::string_view name) {
  for (unsigned i = 0; i < m.signal_count; ++i) {
    if (name == m.signals[i].name) return m.signals[i];
  }
  detail::no_such_signal();
  return m.signals[0];
}

inline constexpr const Signal& kNmtCommand = signal_named(kNmt, "command");
inline constexpr const Signal& kNmtNode = signal_named(kNmt, "node");
inline constexpr const Signal& kEmcyErrorCode = signal_named(kEmcy, "error_code");
inline constexpr const Signal& kEmcyErrorRegister = signal_named(kEmcy, "error_register");
inline constexpr const Signal& kEmcyVendor = signal_named(kEmcy, "vendor");
inline constexpr const Signal& kTpdo1Statusword = signal_named(kTpdo1, "statusword");
inline constexpr const Signal& kTpdo1PositionActual = signal_named(kTpdo1, "position_actual");
inline constexpr const Signal& kTpdo1CurrentActual = signal_named(kTpdo1, "current_actual");
inline constexpr const Signal& kTpdo2VelocityActual = signal_named(kTpdo2, "velocity_actual");
inline constexpr const Signal& kTpdo3SyncCounter = signal_named(kTpdo3, "sync_counter");
inline constexpr const Signal& kTpdo4ArmPositionActual =
    signal_named(kTpdo4, "arm_position_actual");
// The SYNC's one byte when the controller counts its SYNCs (CiA 301,
// 0x1019 > 0): 1, 2, ... up to the overflow value, then 1 again. The SYNC
// message above has none by default (0x1019 = 0), so it is not in the table.
inline constexpr Signal kSyncCounter{
    "counter", 0, 8, false, kRaw, "", "1 to sync_counter_overflow, then 1 again"};
inline constexpr std::uint8_t kSyncCounterMaxOverflow = 240;  // CiA 301: 2..240
inline constexpr const Signal& kRpdo1Controlword = signal_named(kRpdo1, "controlword");
inline constexpr const Signal& kRpdo1TargetTorque = signal_named(kRpdo1, "target_torque");
inline constexpr const Signal& kRpdo1TargetPosition = signal_named(kRpdo1, "target_position");
inline constexpr const Signal& kSdoRxCommand = signal_named(kSdoRx, "command");
inline constexpr const Signal& kSdoRxIndex = signal_named(kSdoRx, "index");
inline constexpr const Signal& kSdoRxSubindex = signal_named(kSdoRx, "subindex");
inline constexpr const Signal& kSdoRxData = signal_named(kSdoRx, "data");
inline constexpr const Signal& kSdoTxCommand = signal_named(kSdoTx, "command");
inline constexpr const Signal& kSdoTxIndex = signal_named(kSdoTx, "index");
inline constexpr const Signal& kSdoTxSubindex = signal_named(kSdoTx, "subindex");
inline constexpr const Signal& kSdoTxData = signal_named(kSdoTx, "data");
inline constexpr const Signal& kHeartbeatNmtState = signal_named(kHeartbeat, "nmt_state");
inline constexpr const Signal& kLogASeq = signal_named(kLogA, "seq");
inline constexpr const Signal& kLogAQ1 = signal_named(kLogA, "q1");
inline constexpr const Signal& kLogAQ2 = signal_named(kLogA, "q2");
inline constexpr const Signal& kLogAStale = signal_named(kLogA, "stale");
inline constexpr const Signal& kLogBSeq = signal_named(kLogB, "seq");
inline constexpr const Signal& kLogBQ3 = signal_named(kLogB, "q3");
inline constexpr const Signal& kLogBTau1 = signal_named(kLogB, "tau1");
inline constexpr const Signal& kLogBStale = signal_named(kLogB, "stale");
inline constexpr const Signal& kLogCSeq = signal_named(kLogC, "seq");
inline constexpr const Signal& kLogCTau2 = signal_named(kLogC, "tau2");
inline constexpr const Signal& kLogCTau3 = signal_named(kLogC, "tau3");
inline constexpr const Signal& kLogCStale = signal_named(kLogC, "stale");
inline constexpr const Signal& kLogDSeq = signal_named(kLogD, "seq");
inline constexpr const Signal& kLogDQa1 = signal_named(kLogD, "qa1");
inline constexpr const Signal& kLogDQa2 = signal_named(kLogD, "qa2");
inline constexpr const Signal& kLogDStale = signal_named(kLogD, "stale");
inline constexpr const Signal& kLogESeq = signal_named(kLogE, "seq");
inline constexpr const Signal& kLogEQa3 = signal_named(kLogE, "qa3");
inline constexpr const Signal& kLogEStale = signal_named(kLogE, "stale");
inline constexpr const Signal& kControllerEmcyErrorCode =
    signal_named(kControllerEmcy, "error_code");
inline constexpr const Signal& kControllerEmcyErrorRegister =
    signal_named(kControllerEmcy, "error_register");
inline constexpr const Signal& kControllerEmcyFaultCode =
    signal_named(kControllerEmcy, "fault_code");
inline constexpr const Signal& kControllerEmcyCycle = signal_named(kControllerEmcy, "cycle");
inline constexpr const Signal& kControllerHeartbeatNmtState =
    signal_named(kControllerHeartbeat, "nmt_state");
inline constexpr const Signal& kCollisionJoint = signal_named(kCollision, "joint");
inline constexpr const Signal& kCollisionTripped = signal_named(kCollision, "tripped");
inline constexpr const Signal& kCollisionResidual = signal_named(kCollision, "residual");
inline constexpr const Signal& kCollisionThreshold = signal_named(kCollision, "threshold");

// NMT commands and states (CiA 301).
inline constexpr std::uint8_t kNmtStart = 1;
inline constexpr std::uint8_t kNmtStop = 2;
inline constexpr std::uint8_t kNmtEnterPreOperational = 128;
inline constexpr std::uint8_t kNmtResetNode = 129;
inline constexpr std::uint8_t kNmtResetCommunication = 130;
inline constexpr std::uint8_t kNmtStateBootUp = 0;
inline constexpr std::uint8_t kNmtStateStopped = 4;
inline constexpr std::uint8_t kNmtStateOperational = 5;
inline constexpr std::uint8_t kNmtStatePreOperational = 127;

// A CANopen COB-ID of the predefined connection set (CiA 301): a 4-bit
// function code over a 7-bit node ID.
inline constexpr std::uint32_t kFunctionCodeMask = 0x780;
inline constexpr std::uint32_t kNodeIdMask = 0x07F;
inline constexpr std::uint32_t kStandardIdMask = 0x7FF;  // every bit of an 11-bit ID

constexpr std::uint32_t function_code(std::uint32_t can_id) {
  return can_id & kFunctionCodeMask;
}
constexpr std::uint8_t node_id(std::uint32_t can_id) {
  return static_cast<std::uint8_t>(can_id & kNodeIdMask);
}

// The COB-ID of a message for a node (node ignored unless per_node).
constexpr std::uint16_t cob_id(const Message& m, std::uint8_t node) {
  return static_cast<std::uint16_t>(m.per_node ? m.base_id + node : m.base_id);
}

// Writes the low `length` bits of raw into data at start_bit (little endian).
constexpr void pack(std::array<std::uint8_t, 8>& data, const Signal& s, std::int64_t raw) {
  const auto u = static_cast<std::uint64_t>(raw);
  for (unsigned i = 0; i < s.length; ++i) {
    const unsigned bit = s.start_bit + i;
    const auto byte = static_cast<std::uint8_t>(1u << (bit % 8));
    if ((u >> i) & 1u) {
      data[bit / 8] = static_cast<std::uint8_t>(data[bit / 8] | byte);
    } else {
      data[bit / 8] = static_cast<std::uint8_t>(data[bit / 8] & ~byte);
    }
  }
}

// Reads a signal's raw value, sign-extended when the signal is signed.
constexpr std::int64_t unpack(const std::array<std::uint8_t, 8>& data, const Signal& s) {
  std::uint64_t u = 0;
  for (unsigned i = 0; i < s.length; ++i) {
    const unsigned bit = s.start_bit + i;
    if ((static_cast<unsigned>(data[bit / 8]) >> (bit % 8)) & 1u) u |= std::uint64_t{1} << i;
  }
  if (s.is_signed && s.length < 64 && ((u >> (s.length - 1)) & 1u)) {
    u |= ~std::uint64_t{0} << s.length;
  }
  return static_cast<std::int64_t>(u);
}

// The three log frames of one control cycle (LOG_A, LOG_B, LOG_C), from the
// raw log values: q in 2^-20 rad and tau in 2^-16 N m (saturated to 24 bits).
// `stale` marks a cycle whose feedback was missing; every frame carries it.
struct LogPayloads {
  std::array<std::array<std::uint8_t, 8>, 3> data{};
};

inline constexpr std::uint32_t kLogSeqModulo = 1u << 15;

constexpr std::int64_t saturate_signal(const Signal& s, std::int64_t v) {
  const std::int64_t hi = (std::int64_t{1} << (s.length - 1)) - 1;
  return v > hi ? hi : (v < -hi - 1 ? -hi - 1 : v);
}

constexpr LogPayloads pack_log(std::uint32_t seq, bool stale,
                               const std::array<std::int32_t, 3>& q_raw20,
                               const std::array<std::int32_t, 3>& tau_raw16) {
  LogPayloads p;
  const Signal* seq_of[3] = {&kLogASeq, &kLogBSeq, &kLogCSeq};
  const Signal* stale_of[3] = {&kLogAStale, &kLogBStale, &kLogCStale};
  for (unsigned i = 0; i < 3; ++i) {
    pack(p.data[i], *seq_of[i], seq % kLogSeqModulo);
    pack(p.data[i], *stale_of[i], stale ? 1 : 0);
  }
  pack(p.data[0], kLogAQ1, saturate_signal(kLogAQ1, q_raw20[0]));
  pack(p.data[0], kLogAQ2, saturate_signal(kLogAQ2, q_raw20[1]));
  pack(p.data[1], kLogBQ3, saturate_signal(kLogBQ3, q_raw20[2]));
  pack(p.data[1], kLogBTau1, saturate_signal(kLogBTau1, tau_raw16[0]));
  pack(p.data[2], kLogCTau2, saturate_signal(kLogCTau2, tau_raw16[1]));
  pack(p.data[2], kLogCTau3, saturate_signal(kLogCTau3, tau_raw16[2]));
  return p;
}

// The two arm-encoder log frames of a cycle (LOG_D, LOG_E), from the arm
// angles in 2^-20 rad: the same seq and stale mark as its LOG_A..C.
struct ArmLogPayloads {
  std::array<std::array<std::uint8_t, 8>, 2> data{};
};

constexpr ArmLogPayloads pack_arm_log(std::uint32_t seq, bool stale,
                                      const std::array<std::int32_t, 3>& qa_raw20) {
  ArmLogPayloads p;
  pack(p.data[0], kLogDSeq, seq % kLogSeqModulo);
  pack(p.data[1], kLogESeq, seq % kLogSeqModulo);
  pack(p.data[0], kLogDStale, stale ? 1 : 0);
  pack(p.data[1], kLogEStale, stale ? 1 : 0);
  pack(p.data[0], kLogDQa1, saturate_signal(kLogDQa1, qa_raw20[0]));
  pack(p.data[0], kLogDQa2, saturate_signal(kLogDQa2, qa_raw20[1]));
  pack(p.data[1], kLogEQa3, saturate_signal(kLogEQa3, qa_raw20[2]));
  return p;
}

// Worst-case length of a classical CAN data frame with bit stuffing,
// interframe space included: 47 + 8 n + floor((33 + 8 n) / 4) bits with an
// 11-bit ID, 67 + 8 n + floor((53 + 8 n) / 4) with a 29-bit ID.
constexpr std::uint32_t worst_case_frame_bits(std::uint8_t dlc, bool extended = false) {
  const std::uint32_t n = dlc;
  return extended ? 67 + 8 * n + (53 + 8 * n) / 4 : 47 + 8 * n + (33 + 8 * n) / 4;
}

// The frames of one control cycle: SYNC, an RPDO1 and a TPDO1 per drive,
// a TPDO2 per drive when velocity is mapped, and the three log frames; with
// the SYNC counter, its byte in the SYNC and a TPDO3 per drive; with
// arm-side encoders a TPDO4 per drive and the log's LOG_D and LOG_E.
constexpr std::uint32_t cycle_bits(bool with_velocity_pdo, bool with_log,
                                   bool with_sync_counter = false, bool with_arm_encoders = false) {
  std::uint32_t bits = worst_case_frame_bits(with_sync_counter ? 1 : kSync.dlc);
  bits += kDriveCount * (worst_case_frame_bits(kRpdo1.dlc) + worst_case_frame_bits(kTpdo1.dlc));
  if (with_velocity_pdo) bits += kDriveCount * worst_case_frame_bits(kTpdo2.dlc);
  if (with_sync_counter) bits += kDriveCount * worst_case_frame_bits(kTpdo3.dlc);
  if (with_log) bits += 3 * worst_case_frame_bits(8);
  if (with_arm_encoders) {
    bits += kDriveCount * worst_case_frame_bits(kTpdo4.dlc);
    if (with_log) bits += worst_case_frame_bits(kLogD.dlc) + worst_case_frame_bits(kLogE.dlc);
  }
  return bits;
}

// Bus load in per mille at a cycle rate and bit rate.
constexpr std::uint32_t bus_load_per_mille(std::uint32_t cycle_bits_, std::uint32_t rate_hz,
                                           std::uint32_t bitrate) {
  return static_cast<std::uint32_t>(std::uint64_t{cycle_bits_} * rate_hz * 1000 / bitrate);
}

}  // namespace delta::can::protocol
