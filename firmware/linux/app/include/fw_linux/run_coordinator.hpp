// What the Linux port does around each step() of the core: it runs the
// command line's trajectories one after the other, serves the commands of
// the control panel (Modbus), keeps the run's result and the fault history,
// reports state changes, and publishes the status snapshot.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "fw/controller.hpp"
#include "fw_linux/canopen_master.hpp"
#include "fw_linux/control_panel.hpp"
#include "fw_linux/feed_forward_slot.hpp"
#include "fw_linux/linux_hardware.hpp"

namespace fw_linux {

struct NamedRun {
  std::string name;
  fw::CheckedTrajectory trajectory;
};

// "joint limit at tick 1200, joint 2"
std::string describe_check(const fw::TrajectoryCheck& check);

class RunCoordinator {
 public:
  using Controller = fw::Controller<LinuxHardware>;

  // `panel` may be null (no Modbus). Messages go to `out`.
  RunCoordinator(std::vector<NamedRun> runs, bool exit_when_done, ControlPanel* panel,
                 std::ostream& out);

  // Where the status finds the fit id of the model in use (may stay unset).
  void set_feed_forward_slot(const FeedForwardSlot* slot) { feed_forward_slot_ = slot; }

  // After each step() (and the master's send_commands()).
  void after_step(Controller& controller, const LinuxHardware& hw, const CanopenMaster& master);

  // Set once the loop should end: kExitDone, kExitFault or kExitRejected.
  std::optional<int> exit_code() const { return exit_code_; }
  // Whether command-line runs were still to go (for an exit by signal).
  bool unfinished() const { return running_cli_ || next_run_ < runs_.size(); }

 private:
  CommandVerdict handle(Controller& controller, const PanelCommand& command);
  // The state's line on out, and a fault's record in the history (which
  // cancels the command line's remaining runs).
  void report_state_change(const Controller& controller, const CanopenMaster& master);
  // The next command-line run started; false (and the exit code set) when
  // the controller refuses it.
  bool start_command_line_run(Controller& controller);
  // With exit_when_done: the exit code a few cycles after the last run
  // ended or the controller faulted.
  void count_down_to_exit(fw::State state);
  void track_run(const Controller& controller);
  void note_collision(const Controller& controller, const CanopenMaster& master);
  void print_tracking(const fw::TrackingStats& tracking);
  PanelStatus status(const Controller& controller, const LinuxHardware& hw) const;

  std::vector<NamedRun> runs_;
  bool exit_when_done_;
  ControlPanel* panel_;
  std::ostream& out_;
  std::size_t next_run_{0};
  bool running_cli_{false};
  int cycles_to_exit_{-1};
  std::optional<int> exit_code_;
  fw::State last_state_{fw::State::kBoot};
  // The current or last run, whoever started it.
  std::uint16_t run_id_{0};
  delta::modbus::RunResult run_result_{delta::modbus::RunResult::kNone};
  bool run_active_{false};
  std::string run_name_;  // of the run under way, for its tracking line
  bool seen_moving_{false};
  bool stop_commanded_{false};
  bool last_estop_open_{false};
  std::uint16_t fault_count_{0};
  std::uint16_t collision_count_{0};
  std::uint32_t collision_t_ms_{0};  // the last collision's, since the first SYNC
  std::array<FaultRecord, delta::modbus::kFaultHistoryLength> history_{};
  const FeedForwardSlot* feed_forward_slot_{nullptr};
};

}  // namespace fw_linux
