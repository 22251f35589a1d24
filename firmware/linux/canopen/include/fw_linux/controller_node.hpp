// The controller's own CANopen node, node 16 (docs/protocol.md): an NMT
// slave that starts itself (a self-starting NMT master, CiA 302), an SDO
// server over its object dictionary (docs/eds/delta_fw.eds), its heartbeat
// (0x710, every heartbeat_ms, which the drives supervise through 0x1016)
// and an emergency (0x090) when it enters or leaves a fault, with the
// fault code and cycle. The log frames are its TPDOs: sent only while it
// is operational. Program download (CiA 302-3, 0x1F50-0x1F57) goes to
// ProgramDownload; after delta_boot rolled a new program back, the node's
// first emergency says why (docs/flashing.md). The feed-forward and its
// identified model (0x2200) go to FeedForwardSlot.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>

#include "delta/can/sdo.hpp"
#include "delta/canopen/eds.hpp"
#include "delta/canopen/object_table.hpp"
#include "fw/collision.hpp"
#include "fw/faults.hpp"
#include "fw/hardware.hpp"
#include "fw_linux/canopen_master.hpp"
#include "fw_linux/config.hpp"
#include "fw_linux/feed_forward_slot.hpp"
#include "fw_linux/identity.hpp"
#include "fw_linux/program_download.hpp"

namespace fw_linux {

// What the node learns from each control step.
struct StepReport {
  fw::Fault fault{fw::Fault::kNone};
  std::uint32_t cycle{0};
  bool safe_to_update{false};  // no trajectory, drives disabled, brakes engaged
  bool ready{false};           // the controller reached ready (its drives up)
  // With fault collision: the detection (the node sends its frames).
  const fw::CollisionEvent* collision{nullptr};
};
// Safe to update: no trajectory, drives disabled, brakes engaged.
StepReport step_report(fw::State state, fw::Fault fault, std::uint32_t cycle,
                       const fw::SafetyOutputs& outputs,
                       const fw::CollisionEvent* collision = nullptr);

class ControllerNode {
 public:
  ControllerNode(FrameSink& bus, const PortConfig& c, const delta::update::Version& version,
                 ProgramDownload& program, FeedForwardSlot& feed_forward);
  ControllerNode(const ControllerNode&) = delete;
  ControllerNode& operator=(const ControllerNode&) = delete;

  // An NMT command (for node 16 or all) or an SDO request to node 16.
  void on_frame(const delta::can::Frame& f, std::uint64_t now_us);
  // After every control step: boot-up, emergencies, the heartbeat and the
  // SDO server's timeouts.
  void after_step(const StepReport& step, std::uint64_t now_us);

  // The latest log record's three frames (LOG_A..C), which 0x2100-0x2102
  // give by SDO as TPDO1-3 map them.
  void note_log_frames(const std::array<std::array<std::uint8_t, 8>, 3>& frames) {
    log_frames_ = frames;
  }
  // The same for LOG_D and LOG_E (arm_encoders): 0x2104 maps them.
  void note_arm_log_frames(const std::array<std::array<std::uint8_t, 8>, 2>& frames) {
    arm_log_frames_ = frames;
  }

  // CiA 301: PDOs only in operational.
  bool pdos_allowed() const { return nmt_ == kOperational; }
  std::uint8_t nmt_state() const { return nmt_; }
  // Where `eds` and this node's objects disagree; "" if they agree.
  std::string eds_mismatch(const delta::canopen::Eds& eds);

 private:
  static constexpr std::uint8_t kOperational = 5;
  struct Context {
    ControllerNode& node;
  };
  using Table = delta::canopen::ObjectTable<Context>;
  static std::span<const Table::Scalar> scalars();
  static std::span<const Table::Text> texts();
  static std::span<const Table::Domain> domains();

  delta::can::sdo::AbortCode model_piece(std::uint32_t offset, std::span<const std::uint8_t> data,
                                         bool last);
  void handle_nmt(const delta::can::Frame& f);
  void reset_communication();
  void flush_sdo(std::uint64_t now_us);
  void send(std::uint32_t id, std::uint8_t dlc, const std::array<std::uint8_t, 8>& data);
  void emergency(std::uint16_t code, std::uint16_t fault_code, std::uint32_t cycle);
  void collision_frames(const fw::CollisionEvent& e);

  FrameSink& bus_;
  delta::update::Version version_;
  ProgramDownload& program_;
  FeedForwardSlot& feed_forward_;
  // A model download (0x2200:1) until its last piece.
  delta::controller::ModelRecordBytes model_download_{};
  std::uint32_t model_download_bytes_{0};
  std::uint32_t period_us_;
  std::uint8_t sync_counter_overflow_;
  std::uint16_t configured_heartbeat_ms_;
  std::uint16_t heartbeat_ms_;
  std::uint32_t since_heartbeat_us_{0};
  std::uint8_t nmt_{kOperational};
  bool boot_up_due_{true};
  fw::Fault fault_{fw::Fault::kNone};  // as of the last step (0x1001)
  bool safe_to_update_{false};         // as of the last step
  bool revert_reported_{false};
  fw::Fault last_reported_{fw::Fault::kNone};
  bool arm_encoders_;  // TPDO5 and TPDO6 (LOG_D, LOG_E) on
  std::array<std::array<std::uint8_t, 8>, 3> log_frames_{};
  std::array<std::array<std::uint8_t, 8>, 2> arm_log_frames_{};
  std::array<std::uint8_t, 8> collision_frame_{};  // the last one sent
  Table table_;
  std::optional<delta::can::sdo::Server> server_;
};

}  // namespace fw_linux
