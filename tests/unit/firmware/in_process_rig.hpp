// The controller, the CANopen master and the emulator closed in one
// process (the same code as delta_fw and delta_drive_emu, frames passed by
// hand in bus order), for the port's tests.
#pragma once

#include <deque>
#include <utility>
#include <vector>

#include "delta/can/protocol.hpp"
#include "emu/emulator.hpp"
#include "fw/controller.hpp"
#include "fw_linux/canopen_master.hpp"
#include "fw_linux/collision_setting.hpp"
#include "fw_linux/config.hpp"
#include "fw_linux/controller_node.hpp"
#include "fw_linux/linux_hardware.hpp"
#include "fw_linux/safety_io.hpp"

namespace fw_linux {

// The controller, the CANopen master and the emulator, in one process.
class InProcessBus : public FrameSink {
 public:
  explicit InProcessBus(const emu::EmulatorConfig& ec)
      : emulator_(ec,
                  [this](const delta::can::Frame& f, std::uint32_t) { to_master_.push_back(f); }) {}
  bool send(const delta::can::Frame& f) override {
    sent_.push_back(f);
    if (!f.error_frame && f.id != lost_id_) emulator_.on_frame(f);
    return true;
  }
  // Frames with this ID no longer reach the emulator (~0u: none lost).
  void lose(std::uint32_t id) { lost_id_ = id; }
  // Answers with this ID come after the cycle's deadline while set (~0u:
  // none): deliver(m, true) holds them back for the next deliver.
  void make_late(std::uint32_t id) { late_id_ = id; }
  void deliver(CanopenMaster& m, bool in_window = false) {
    held_.clear();  // kept between calls: a deque allocates when it is made
    while (!to_master_.empty()) {
      delta::can::Received r;
      r.frame = to_master_.front();
      to_master_.pop_front();
      if (in_window && r.frame.id == late_id_) {
        held_.push_back(r.frame);
        continue;
      }
      if (r.frame.error_frame) r.error = delta::can::decode_error_frame(r.frame.id, r.frame.data);
      m.on_frame(r, 0);
    }
    std::swap(to_master_, held_);
  }
  emu::Emulator emulator_;
  std::deque<delta::can::Frame> to_master_;
  std::deque<delta::can::Frame> held_;  // deliver()'s late answers
  std::vector<delta::can::Frame> sent_;
  std::uint32_t lost_id_{~0u};
  std::uint32_t late_id_{~0u};
};

// The version the rigs' controller reports.
inline constexpr delta::update::Version kVersion{3, 14, 15};

struct Rig {
  explicit Rig(const emu::EmulatorConfig& ec = {}) : Rig(config(), ec) {}
  Rig(const PortConfig& c, const emu::EmulatorConfig& ec)
      : bus(ec),
        master(c, bus),
        hw(master, io, bus),
        controller(hw, controller_config(c)),
        program(std::nullopt, controller_identity(kVersion)),
        feed_forward(c, controller_config(c)),
        node(bus, c, kVersion, program, feed_forward) {
    bus.emulator_.boot();
    feed_forward.set_apply(
        [this, c](const fw::FeedForwardConfig& f, const std::optional<fw::CollisionThresholds>& t) {
          return apply_model(controller, c, f, t).has_value();
        });
    feed_forward.set_check(
        [c](const fw::FeedForwardConfig& f, const std::optional<fw::CollisionThresholds>& t) {
          return collision_check(c, f, t);
        });
  }
  static PortConfig config() {
    PortConfig c;
    c.mode = CycleMode::kLockStep;
    c.feed_forward_store = "";  // a test that loads a model gives its own
    return c;
  }
  void cycle() {
    bus.deliver(master);
    master.begin_cycle(0);
    bus.deliver(master, true);
    master.end_window();
    controller.step();
    master.send_commands();
    node.after_step(step_report(controller.state(), controller.fault(), controller.cycles(),
                                hw.last_outputs(), &controller.collision()),
                    0);
  }
  InProcessBus bus;
  CanopenMaster master;
  SimulatedSafetyIo io;
  LinuxHardware hw;
  fw::Controller<LinuxHardware> controller;
  ProgramDownload program;
  FeedForwardSlot feed_forward;
  ControllerNode node;
};

}  // namespace fw_linux
