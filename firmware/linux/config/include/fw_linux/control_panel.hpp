// Between the control loop and the Modbus server (or any other thread that
// commands the controller): the loop publishes a status snapshot every
// cycle and takes at most one command per cycle; the other side reads the
// snapshot and submits commands, waiting for the loop's verdict.
//
// The loop's side never blocks: it only try_locks, and a busy lock defers
// the snapshot or the command to the next cycle. The other side holds the
// lock only to copy a struct.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>

#include "delta/modbus/register_map.hpp"
#include "fw/controller.hpp"

namespace fw_linux {

struct FaultRecord {
  fw::Fault fault{fw::Fault::kNone};
  std::uint32_t cycle{0};
};

struct PanelStatus {
  fw::State state{fw::State::kBoot};
  fw::Fault fault{fw::Fault::kNone};
  std::uint32_t cycle{0};
  std::uint16_t io_bits{0};  // delta::modbus::kIo*
  std::uint16_t run_id{0};
  delta::modbus::RunResult run_result{delta::modbus::RunResult::kNone};
  std::uint32_t run_tick{0};
  std::uint32_t run_length{0};
  std::uint32_t log_records{0};
  std::uint32_t stale_log_records{0};
  std::uint16_t fault_count{0};
  std::array<FaultRecord, delta::modbus::kFaultHistoryLength> fault_history{};  // newest first
  fw::FeedForwardConfig feed_forward{};  // in use: what a trajectory check covers
  std::uint32_t model_fit_id{0};         // of the model loaded or configured, 0 none
  std::array<std::int32_t, 3> q_urad{};
  std::array<std::int32_t, 3> tau_uNm{};
  // The tracking error of run tracking_run_id (fw::TrackingStats).
  std::uint16_t tracking_run_id{0};
  std::uint32_t tracking_ticks{0};
  std::array<std::uint32_t, 3> tracking_rms_nrad{};
  std::array<std::uint32_t, 3> tracking_max_nrad{};
  // The collision detector and its last detection (docs/safety.md).
  bool collision_detect{false};
  std::uint16_t collision_count{0};
  std::uint16_t collision_joint{0};  // 1-3, 0 none yet
  std::uint32_t collision_t_ms{0};   // since the first SYNC
  std::array<std::int32_t, 3> collision_residual_uNm{};
  std::array<std::int32_t, 3> collision_threshold_uNm{};
};

struct PanelCommand {
  delta::modbus::Command kind{delta::modbus::Command::kNone};
  std::optional<fw::CheckedTrajectory> trajectory;  // with kStart
  std::uint16_t trajectory_id{0};
};

struct CommandVerdict {
  bool accepted{false};
  delta::modbus::Rejection why{delta::modbus::Rejection::kNone};
  fw::TrajectoryCheck check{};
};

class ControlPanel {
 public:
  // --- the loop's side (never blocks) ---
  // Hands the waiting command, if the lock is free and there is one, to
  // `handle` (CommandVerdict(const PanelCommand&)), under the lock, then
  // publishes `status_after()` (PanelStatus()), and only then wakes the
  // submitter with the verdict: a client that reads the status after its
  // command was answered sees the command's effect. Both must be quick.
  template <class Handler, class StatusAfter>
  void serve(Handler&& handle, StatusAfter&& status_after) {
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock() || !pending_) return;
    verdict_ = handle(static_cast<const PanelCommand&>(*pending_));
    status_ = status_after();
    verdict_ticket_ = pending_ticket_;
    pending_.reset();
    lock.unlock();
    answered_.notify_all();
  }
  void publish(const PanelStatus& status);  // skipped when the lock is busy
  const std::atomic<bool>& log_enabled() const { return log_enabled_; }

  // --- the other side ---
  PanelStatus status() const;
  void set_log_enabled(bool on) { log_enabled_.store(on, std::memory_order_relaxed); }
  // Submits a command and waits up to `timeout` for the loop's verdict;
  // nullopt when the loop did not take it in time (it is withdrawn then)
  // or another command is still waiting.
  std::optional<CommandVerdict> submit(PanelCommand command, std::chrono::milliseconds timeout);

 private:
  mutable std::mutex mutex_;
  std::condition_variable answered_;
  PanelStatus status_{};
  std::optional<PanelCommand> pending_;
  std::uint64_t pending_ticket_{0};
  std::uint64_t next_ticket_{0};
  std::uint64_t verdict_ticket_{0};
  CommandVerdict verdict_{};
  std::atomic<bool> log_enabled_{true};
};

}  // namespace fw_linux
