// The controller's side of the CAN bus: a CANopen master for the three
// CiA 402 drives (docs/protocol.md). It brings them up by SDO, runs the
// cyclic exchange (SYNC, TPDOs in, RPDOs out), consumes their heartbeats and
// emergencies, and converts drive units to the core's Q formats. It is the
// "drives" part of the core's hardware interface (fw/hardware.hpp).
//
// The cycle, driven by the port's loop:
//   on_frame() for what arrived since the last window (late answers),
//   begin_cycle()  -> SYNC (once the drives are operational),
//   on_frame() until exchange_complete() or the deadline,
//   end_window(),
//   the core's step(): configure_drives(), read_feedback(), command_torque(),
//   send_commands() -> RPDOs.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "delta/can/cia402.hpp"
#include "delta/can/sdo.hpp"
#include "delta/can/socketcan.hpp"
#include "fw/hardware.hpp"
#include "fw_linux/config.hpp"
#include "fw_linux/drive_plan.hpp"
#include "fw_linux/drive_units.hpp"

namespace fw_linux {

// Where frames go: the SocketCAN socket in the port, a recorder in tests.
class FrameSink {
 public:
  virtual ~FrameSink() = default;
  virtual bool send(const delta::can::Frame& f) = 0;
};

class CanopenMaster {
 public:
  // Plans each drive's bring-up (drive_plan.hpp); throws ConfigError when
  // a plan has problems (validate() reports them first).
  CanopenMaster(const PortConfig& config, FrameSink& bus);

  // --- the cycle ---
  void begin_cycle(std::uint64_t now_us);
  void on_frame(const delta::can::Received& r, std::uint64_t now_us);
  bool exchange_complete() const;
  void end_window();
  void send_commands();
  // The earliest time at which a pending SDO request times out (0: none).
  std::uint64_t sdo_deadline_us() const;

  // --- the core's hardware interface (drives) ---
  fw::DriveConfigProgress configure_drives();
  void enable_drives(bool on) {
    enable_ = on;
    quick_stop_ = false;
    for (Drive& d : drives_) d.has_reference = false;  // until this run's first
  }
  // CiA 402 quick stop: controlword 0x0002 until the next enable; the
  // drive brakes on its quick-stop ramp (0x6085) and, as its quick-stop
  // option code (0x605A) says, stays in quick stop active or disables.
  void quick_stop_drives() {
    enable_ = false;
    quick_stop_ = true;
  }
  void read_feedback(std::array<fw::DriveFeedback, 3>& out);
  void command_torque(const std::array<Q12_19, 3>& joint_torque_Nm);
  // The arms' reference this cycle: RPDO1's target position (0x607A)
  // carries it while the drives are enabled for a run, their own position
  // otherwise (docs/protocol.md).
  void command_reference(const fw::JointAnglesQ& arm_reference_rad);

  // Restart the bring-up (after the core's reset).
  void restart();

  // A clean exit: every drive to pre-operational, where it no longer expects
  // SYNCs or the controller's heartbeat (a crash leaves them operational,
  // and their heartbeat consumers fault them).
  void leave_network();

  // What went wrong most recently, in words (node, object, value). Built
  // when asked, outside the control loop: the cycle only records the facts.
  std::string last_problem() const;
  std::uint64_t late_frames() const { return late_frames_; }
  // SYNCs sent so far, and the cycle's period: the time since the first
  // SYNC, as the emulator counts it.
  std::uint64_t syncs_sent() const { return syncs_sent_; }
  std::uint32_t period_us() const { return config_.period_us; }
  bool arm_encoders() const { return config_.arm_encoders; }

 private:
  // kStarting: the drives are operational (cyclic exchange running) and any
  // drive still in fault gets a fault-reset edge before the core sees them.
  enum class Phase : std::uint8_t { kIdle, kConfiguring, kStarting, kCyclic, kFailed };
  bool cyclic() const { return phase_ == Phase::kStarting || phase_ == Phase::kCyclic; }
  bool failure_reported_{false};  // kFailed was returned to the core
  struct Drive {
    std::uint8_t node{0};
    DriveUnits units{};
    const DrivePlan* plan{nullptr};
    // bring-up: the plan's transfers
    unsigned sdo_step{0};
    delta::can::sdo::Client sdo{};
    std::array<std::uint8_t, 4> sdo_bytes{};  // the value written or read
    unsigned sdo_attempts{0};
    std::uint32_t rated_current_mA{0};
    std::uint32_t rated_torque_mNm{0};
    // cyclic
    bool got_tpdo1{false};
    bool got_tpdo2{false};
    bool got_tpdo4{false};  // the arm-side encoder (arm_encoders only)
    // With a SYNC counter, a cycle's TPDO1/TPDO2 are held until TPDO3 says
    // they answer this cycle's SYNC.
    struct Sample {
      std::uint16_t statusword{0};
      std::int32_t position_counts{0};
      std::int16_t current_per_mille{0};
      std::int32_t velocity_counts_s{0};
      std::int32_t arm_counts{0};
      unsigned parts{0};  // the sample's PDOs come: bit 0 `sample`, bit 1 `sample_rest`
      bool tpdo1{false};  // the sample is whole
      bool tpdo2{false};
      bool tpdo4{false};
    };
    Sample held{};
    bool late{false};
    bool malformed{false};
    bool emergency{false};
    bool rebooted{false};
    std::uint16_t statusword{0};
    delta::can::cia402::State state{delta::can::cia402::State::kNotReadyToSwitchOn};
    std::int32_t position_counts{0};
    std::int32_t previous_counts{0};
    std::uint64_t previous_cycle{0};  // of the last good sample; 0: none yet
    std::int32_t velocity_counts_s{0};
    std::int32_t arm_counts{0};  // 0x60E4:1, in 0x6064's units
    std::int16_t current_per_mille{0};
    std::uint64_t last_heartbeat_cycle{0};
    bool heartbeat_seen{false};
    std::uint16_t controlword{0};
    Q12_19 command_current_A{};
    bool has_reference{false};
    std::int32_t reference_counts{0};
  };

  static bool bring_up_done(const Drive& d) { return d.sdo_step >= d.plan->actions.size(); }
  void send_sdo(Drive& d, std::uint64_t now_us);
  void pump_sdo(Drive& d);
  std::string step_text(const Drive& d) const;
  std::string joint_key(const Drive& d) const;
  void take_step_result(Drive& d, std::uint32_t value);
  bool identity_matches(Drive& d, std::uint32_t found);
  bool checked(Drive& d, std::uint32_t value);
  // key: the configuration's key under the joint's ("rated_current_A").
  bool rated_value(Drive& d, std::uint32_t value, std::uint32_t& kept, bool set, double configured,
                   const char* key);
  void handle_sdo_response(Drive& d, const delta::can::Frame& f);
  bool counted() const { return config_.sync_counter_overflow != 0; }
  void handle_tpdo(Drive& d, const delta::can::Frame& f, const PlannedPdo& pdo);
  void take_sync_echo(Drive& d, const delta::can::Frame& f);
  void take_held(Drive& d) const;
  static void hold_sample(Drive& d, const delta::can::Frame& f, const PlannedPdo& pdo);
  void fail(const std::string& why);
  Drive* drive_for(std::uint8_t node);
  std::string sample_text(std::uint8_t node) const;
  const JointDrive& joint(const Drive& d) const {
    return config_.joints[static_cast<std::size_t>(&d - drives_.data())];
  }

  PortConfig config_;
  DrivePlans plans_;
  fw::ControllerConfig core_;
  FrameSink& bus_;
  std::array<Drive, 3> drives_{};
  Phase phase_{Phase::kIdle};
  bool window_open_{false};
  bool bus_error_{false};
  bool enable_{false};
  bool quick_stop_{false};
  std::uint64_t syncs_sent_{0};
  std::uint64_t cycle_{0};
  std::uint8_t sync_counter_{0};  // of the last SYNC sent (with a counter)
  std::uint64_t now_us_{0};
  std::uint64_t late_frames_{0};
  std::uint64_t heartbeat_timeout_cycles_{1};
  std::uint64_t sdo_timeout_us_{0};

  // The facts of the most recent problem of the cyclic exchange, recorded
  // without allocating; last_problem() puts them into words.
  struct CyclicProblem {
    enum class Kind : std::uint8_t {
      kNone,
      kMalformedPdo,
      kLatePdo,
      kStalePdo,  // TPDO3 carries another SYNC's counter
      kBusError,
      kEmergency,
      kRebooted,
      kHeartbeatLost,
      kNoTpdo1,
      kSilentAfterStart,  // no TPDO1 yet after the NMT start
      kStaysInFault,      // still in fault after a fault reset
    };
    Kind kind{Kind::kNone};
    std::uint8_t node{0};
    std::uint8_t pdo{1};           // kMalformedPdo, kLatePdo, kStalePdo: TPDO 1, 2 or 3
    std::uint32_t can_id{0};       // kMalformedPdo, kLatePdo, kStalePdo
    std::uint8_t counter{0};       // kStalePdo: the counter it carries
    std::uint8_t sync_counter{0};  // kStalePdo: this cycle's SYNC's
    std::uint8_t dlc{0};           // kMalformedPdo: received and expected
    std::uint8_t expected_dlc{0};  //
    bool bus_off{false};           // kBusError: bus-off, else error passive
    std::uint32_t error_class{0};  // kBusError: the error frame's class bits
    std::uint16_t emcy_code{0};    // kEmergency
    std::uint64_t cycle{0};        // kNoTpdo1: the cycle; kHeartbeatLost: cycles silent
  };
  void record(const CyclicProblem& p) {
    cyclic_problem_ = p;
    bring_up_problem_.clear();  // keeps its capacity: no allocation
  }
  void clear_problem() { record({}); }
  CyclicProblem cyclic_problem_{};
  std::string bring_up_problem_;  // set by fail(), outside the cyclic exchange
};

}  // namespace fw_linux
