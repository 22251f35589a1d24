// The core's hardware interface (fw/hardware.hpp) on Linux: the drives are
// the CANopen master, the safety lines a SafetyIo backend, and the log sink
// the controller's LOG_A..C frames (and LOG_D, LOG_E) on the same bus.
#pragma once

#include <atomic>

#include "delta/can/protocol.hpp"
#include "delta/can/socketcan.hpp"
#include "fw_linux/canopen_master.hpp"
#include "fw_linux/controller_node.hpp"
#include "fw_linux/safety_io.hpp"

namespace fw_linux {

// A FrameSink on a SocketCAN socket.
class SocketSink : public FrameSink {
 public:
  explicit SocketSink(delta::can::Socket& socket) : socket_(socket) {}
  bool send(const delta::can::Frame& f) override {
    const bool ok = socket_.send(f) == delta::can::SendResult::kOk;
    if (!ok) ++failures_;
    return ok;
  }
  std::uint64_t failures() const { return failures_; }

 private:
  delta::can::Socket& socket_;
  std::uint64_t failures_{0};
};

// The log record as the three log frames' payloads (docs/protocol.md).
delta::can::protocol::LogPayloads log_payloads(const fw::LogRecord& r);
// The three log frames on the bus.
bool send_log_frames(FrameSink& bus, const delta::can::protocol::LogPayloads& payloads);
// The arm-side encoders' log frames (LOG_D, LOG_E), with arm_encoders.
delta::can::protocol::ArmLogPayloads arm_log_payloads(const fw::LogRecord& r);
bool send_arm_log_frames(FrameSink& bus, const delta::can::protocol::ArmLogPayloads& payloads);

class LinuxHardware {
 public:
  LinuxHardware(CanopenMaster& drives, SafetyIo& io, FrameSink& log_bus)
      : drives_(drives), io_(io), log_bus_(log_bus) {}

  fw::DriveConfigProgress configure_drives() { return drives_.configure_drives(); }
  void enable_drives(bool on) { drives_.enable_drives(on); }
  void quick_stop_drives() { drives_.quick_stop_drives(); }
  void read_feedback(std::array<fw::DriveFeedback, 3>& fb) { drives_.read_feedback(fb); }
  void command_torque(const std::array<Q12_19, 3>& t) { drives_.command_torque(t); }
  void command_reference(const fw::JointAnglesQ& q) { drives_.command_reference(q); }
  bool estop_open() {
    estop_open_ = io_.estop_open();
    return estop_open_;
  }
  void set_outputs(const fw::SafetyOutputs& o) {
    outputs_ = o;
    io_.set_outputs(o);
  }
  // With log frames switched off (Modbus log_enable 0) a record is dropped
  // here, and the core's sequence still counts it.
  // The node's mapped objects (0x2100-0x2102, 0x2104) hold the latest record either way.
  bool log(const fw::LogRecord& r) {
    const delta::can::protocol::LogPayloads payloads = log_payloads(r);
    const bool arm = drives_.arm_encoders();
    const delta::can::protocol::ArmLogPayloads arm_payloads =
        arm ? arm_log_payloads(r) : delta::can::protocol::ArmLogPayloads{};
    if (node_ != nullptr) {
      node_->note_log_frames(payloads.data);
      if (arm) node_->note_arm_log_frames(arm_payloads.data);
    }
    if (log_enabled_ != nullptr && !log_enabled_->load(std::memory_order_relaxed)) return true;
    if (node_ != nullptr && !node_->pdos_allowed()) return true;  // NMT: not operational
    const bool sent = send_log_frames(log_bus_, payloads);
    return arm ? send_arm_log_frames(log_bus_, arm_payloads) && sent : sent;
  }
  void gate_log(const std::atomic<bool>* enabled) { log_enabled_ = enabled; }
  // The log frames are the controller node's TPDOs: sent while it is operational.
  void gate_pdos(ControllerNode* node) { node_ = node; }

  // What the last cycle read and wrote on the safety lines.
  bool last_estop_open() const { return estop_open_; }
  const fw::SafetyOutputs& last_outputs() const { return outputs_; }

 private:
  CanopenMaster& drives_;
  SafetyIo& io_;
  FrameSink& log_bus_;
  const std::atomic<bool>* log_enabled_{nullptr};
  ControllerNode* node_{nullptr};
  bool estop_open_{false};
  fw::SafetyOutputs outputs_{};
};

}  // namespace fw_linux
