// The bring-up of each drive, planned from what the drive can do (its EDS
// or DCF, CiA 306) and the configuration (docs/drives.md): the torque mode,
// the feedback and its unit, the cycle period, the limits, the heartbeats,
// the PDOs, and the SDO transfers that set them up, in order. The master
// carries a plan out (canopen_master.cpp); `delta_fw --check-config`
// prints it, or every problem that keeps a drive from serving.
//
// Without an EDS a drive is taken for the generic CiA 402 profile of
// docs/drives.md (the emulated drive): every object the bring-up uses is
// assumed, and the rated values are read from the drive.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "delta/can/cia402.hpp"
#include "fw_linux/config.hpp"

namespace fw_linux {

// What the master does with the value of a read (or after a write).
enum class SdoCheck : std::uint8_t {
  kNone,
  kDeviceType,         // a CiA 402 device (0x....0192)
  kVendorId,           // 0x1018:1..4 against the expected identity
  kProductCode,        //
  kRevision,           // by its major part
  kSerial,             //
  kRatedCurrent,       // 0x6075 [mA]: kept; must not be 0; equal to a configured one
  kRatedTorque,        // 0x6076 [mN m]: the same
  kEncoderIncrements,  // 0x608F:1: equal to jointN.counts_per_rev
  kModeDisplay,        // 0x6061: the mode written to 0x6060
};

// One SDO transfer of a bring-up.
struct SdoAction {
  delta::can::od::Object object;
  std::uint8_t size{0};    // bytes written; 0: a read
  std::uint32_t value{0};  // what is written (resolved for the node)
  SdoCheck check{SdoCheck::kNone};
  std::string what;   // "modes of operation"
  std::string shown;  // the value as the plan prints it ("10, cyclic synchronous torque")
};

// A PDO's mapping: entries index << 16 | sub-index << 8 | length in bits.
struct PdoLayout {
  std::uint8_t count{0};
  std::array<std::uint32_t, 8> entries{};
  unsigned bytes() const;
  // The byte offset of `object` in the PDO; -1 if it is not mapped.
  int offset_of(delta::can::od::Object object) const;
};

// A PDO the controller uses.
struct PlannedPdo {
  bool used{false};
  unsigned number{1};  // RPDOn or TPDOn, 1 to 4: its predefined COB-ID
  std::uint32_t cob_id{0};
  std::uint8_t transmission_type{1};
  PdoLayout layout;
  bool mapping_written{true};  // false: the drive's fixed mapping, as it is
};

enum class Feedback : std::uint8_t {
  kCurrent,  // 0x6078, current actual value
  kTorque,   // 0x6077, torque actual value
};

struct DrivePlan {
  unsigned joint{0};  // 0 to 2
  std::uint8_t node{1};
  std::string eds_path;  // empty: the generic profile
  std::int8_t mode{delta::can::cia402::kModeCyclicSynchronousTorque};
  std::string mode_reason;
  Feedback feedback{Feedback::kCurrent};
  TorqueUnit torque_unit{TorqueUnit::kPerMille};
  // The rated values the units use: fixed by the configuration or the EDS
  // (non-zero), or read from the drive at bring-up (0 here).
  std::uint32_t rated_current_mA{0};
  std::uint32_t rated_torque_mNm{0};
  std::string cycle;  // how the drive learns the cycle period, in words
  PlannedPdo rpdo;    // controlword, target torque[, target position]
  PlannedPdo sample;  // TPDO: statusword, position actual, the feedback
  // A second TPDO with what `sample`'s does not carry: a drive whose fixed
  // TPDO has the feedback, and another TPDO the position (not used: all in one).
  PlannedPdo sample_rest;
  PlannedPdo velocity;  // TPDO: velocity actual (velocity_pdo only)
  PlannedPdo echo;      // TPDO: the SYNC counter of the sample (sync_counter_overflow > 0 only)
  PlannedPdo arm;       // TPDO4: the arm-side encoder, 0x60E4:1 (arm_encoders only)
  // Every TPDO the controller may receive from the drive (those not used
  // have used = false).
  std::array<const PlannedPdo*, 5> tpdos() const {
    return {&sample, &sample_rest, &velocity, &echo, &arm};
  }
  std::vector<SdoAction> actions;
  std::vector<std::string> warnings;
};

struct DrivePlans {
  std::array<DrivePlan, 3> drives;
  // Every problem found, each naming the joint, the object, the file and
  // line where there is one, and why.
  std::vector<std::string> problems;
};

// The plans of the three drives. Never throws for a drive's shortcomings:
// they are problems.
DrivePlans plan_drives(const PortConfig& c);

// "0x6071:00": an object as plans and bring-up messages name it.
std::string object_text(delta::can::od::Object o);

// A plan in words: the mode, the feedback, the PDOs with their COB-IDs and
// transmission types, every SDO transfer with its value and unit.
std::string describe_plan(const DrivePlan& plan);

}  // namespace fw_linux
