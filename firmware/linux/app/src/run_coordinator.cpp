#include "fw_linux/run_coordinator.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ostream>

#include "fw_linux/exit_codes.hpp"
#include "fw_linux/trajectories.hpp"

namespace fw_linux {

namespace mb = delta::modbus;

namespace {

// raw * 10^6 / 2^frac, rounded: micro-units of a Q value for the registers.
std::int32_t micro(std::int32_t raw, int frac) {
  const std::int64_t v = delta::fx::shift_round(std::int64_t{raw} * 1000000, frac);
  return delta::fx::saturate32(v);
}

}  // namespace

std::string describe_check(const fw::TrajectoryCheck& c) {
  std::string s = fw::trajectory_fault_name(c.fault);
  s += " at tick " + std::to_string(c.tick);
  if (c.joint >= 0) s += ", joint " + std::to_string(c.joint + 1);
  return s;
}

RunCoordinator::RunCoordinator(std::vector<NamedRun> runs, bool exit_when_done, ControlPanel* panel,
                               std::ostream& out)
    : runs_(std::move(runs)), exit_when_done_(exit_when_done), panel_(panel), out_(out) {}

void RunCoordinator::after_step(Controller& c, const LinuxHardware& hw,
                                const CanopenMaster& master) {
  const fw::State state = c.state();
  last_estop_open_ = hw.last_estop_open();
  if (state != last_state_) report_state_change(c, master);
  track_run(c);

  // The command line's runs, one after the other, from ready.
  if (state == fw::State::kReady && !run_active_) {
    if (next_run_ < runs_.size() && exit_code_ == std::nullopt) {
      if (!start_command_line_run(c)) return;
    } else if (exit_when_done_ && cycles_to_exit_ < 0) {
      cycles_to_exit_ = 2;  // the disabling RPDOs go out first
    }
  }
  count_down_to_exit(state);

  if (panel_ != nullptr) {
    panel_->serve([&](const PanelCommand& command) { return handle(c, command); },
                  [&] { return status(c, hw); });
    panel_->publish(status(c, hw));
  }
  last_state_ = state;
}

namespace {

// Which joint left its range (fault 4), at which angle, and what to check
// when it is not really there: a joint far outside at the run's start is
// an encoder read with the wrong scale or zero.
std::string joint_outside_limits(const RunCoordinator::Controller& c) {
  const fw::JointLimits& limits = c.bounds().limits;
  const auto rad = [](delta::fx::Q3_28 v) { return std::ldexp(static_cast<double>(v.raw()), -28); };
  for (unsigned j = 0; j < 3; ++j) {
    const double q = rad(c.feedback()[j].position_rad);
    if (q >= rad(limits.min_rad) && q <= rad(limits.max_rad)) continue;
    char text[400];
    std::snprintf(text, sizeof text,
                  "joint %u at %.4g rad, outside [%.4g, %.4g] rad; if the arm is not there, the "
                  "drive's position is read with the wrong scale or zero: check joint%u."
                  "counts_per_rev (the drive's 0x608F:1), joint%u.gear_ratio and joint%u.zero_rad",
                  j + 1, q, rad(limits.min_rad), rad(limits.max_rad), j + 1, j + 1, j + 1);
    return text;
  }
  return "no joint outside the range now";
}

}  // namespace

void RunCoordinator::report_state_change(const Controller& c, const CanopenMaster& master) {
  const fw::State state = c.state();
  out_ << "delta_fw: " << fw::state_name(state);
  if (state == fw::State::kFault) {
    out_ << ", fault " << static_cast<int>(c.fault()) << " (" << fw::fault_name(c.fault()) << ")";
    if (!master.last_problem().empty()) out_ << ": " << master.last_problem();
    if (c.fault() == fw::Fault::kJointLimit) out_ << ": " << joint_outside_limits(c);
    out_ << " at cycle " << c.cycles();
    // Newest first; one record per entry into the fault state.
    for (std::size_t i = history_.size() - 1; i > 0; --i) history_[i] = history_[i - 1];
    history_[0] = FaultRecord{c.fault(), c.cycles()};
    ++fault_count_;
    if (next_run_ < runs_.size() || running_cli_) {
      out_ << "; the remaining command-line runs are cancelled";
      running_cli_ = false;
      next_run_ = runs_.size();
    }
  }
  out_ << "\n";
  if (state == fw::State::kFault && c.fault() == fw::Fault::kCollision && c.collided()) {
    note_collision(c, master);
  }
}

bool RunCoordinator::start_command_line_run(Controller& c) {
  const NamedRun& run = runs_[next_run_];
  const fw::StartResult r = c.start(run.trajectory);
  if (!r.accepted) {
    out_ << "delta_fw: trajectory '" << run.name << "' rejected: "
         << (run.trajectory.checked_against(c.bounds())
                 ? describe_check(r.check)
                 : std::string("it was checked at start against another feed-forward (a "
                               "model was loaded since); start delta_fw again to run it "
                               "with the model in use"))
         << "\n";
    exit_code_ = kExitRejected;
    return false;
  }
  out_ << "delta_fw: running " << run.name << "\n";
  run_name_ = run.name;
  ++next_run_;
  running_cli_ = true;
  ++run_id_;
  run_result_ = mb::RunResult::kRunning;
  run_active_ = true;
  seen_moving_ = false;
  stop_commanded_ = false;
  return true;
}

void RunCoordinator::count_down_to_exit(fw::State state) {
  if (state == fw::State::kFault && exit_when_done_ && cycles_to_exit_ < 0) {
    cycles_to_exit_ = 10;  // keep the drives disabled and the EMCY seen
  }
  if (cycles_to_exit_ >= 0 && cycles_to_exit_-- == 0 && !exit_code_) {
    exit_code_ = state == fw::State::kFault ? kExitFault : kExitDone;
  }
}

void RunCoordinator::track_run(const Controller& c) {
  if (!run_active_) return;
  const fw::State state = c.state();
  if (state == fw::State::kRunning || state == fw::State::kStopping) {
    seen_moving_ = true;
  } else if (state == fw::State::kFault) {
    run_result_ = mb::RunResult::kFaulted;
    run_active_ = false;
  } else if (state == fw::State::kReady && seen_moving_) {
    run_result_ = stop_commanded_ ? mb::RunResult::kStopped : mb::RunResult::kFinished;
    run_active_ = false;
  }
  if (!run_active_) {
    running_cli_ = false;
    print_tracking(c.tracking());
  }
}

// A collision: counted and timed for the status registers, and printed as
// `collision NAME: t_s=T joint=J residual_Nm=a,b,c threshold_Nm=a,b,c`,
// T in seconds since the first SYNC (docs/safety.md).
void RunCoordinator::note_collision(const Controller& c, const CanopenMaster& master) {
  const fw::CollisionEvent& e = c.collision();
  const auto nm = [](fw::Q12_19 v) { return std::ldexp(static_cast<double>(v.raw()), -19); };
  const double t_s = master.syncs_sent() > 0
                         ? static_cast<double>(master.syncs_sent() - 1) * master.period_us() * 1e-6
                         : 0.0;
  ++collision_count_;
  collision_t_ms_ = static_cast<std::uint32_t>(std::llround(t_s * 1e3));
  char text[320];
  std::snprintf(text, sizeof text,
                "collision %s: t_s=%.4f joint=%u residual_Nm=%.4f,%.4f,%.4f "
                "threshold_Nm=%.4f,%.4f,%.4f\n",
                run_name_.c_str(), t_s, e.joint + 1u, nm(e.residual_Nm[0]), nm(e.residual_Nm[1]),
                nm(e.residual_Nm[2]), nm(e.threshold_Nm[0]), nm(e.threshold_Nm[1]),
                nm(e.threshold_Nm[2]));
  out_ << text;
}

// After each run: `tracking NAME: rms_rad=a,b,c max_rad=a,b,c`, over the
// trajectory's ticks (docs/firmware.md); a run that ended in the approach
// has none.
void RunCoordinator::print_tracking(const fw::TrackingStats& t) {
  if (t.ticks == 0) return;
  char text[256];
  std::array<double, 3> rms{}, largest{};
  for (unsigned j = 0; j < 3; ++j) {
    rms[j] = std::sqrt(std::ldexp(static_cast<double>(t.sum_sq_rad2_q40[j]), -40) / t.ticks);
    largest[j] = std::ldexp(static_cast<double>(t.max_abs_rad[j].raw()), -28);
  }
  std::snprintf(text, sizeof text, "tracking %s: rms_rad=%.6g,%.6g,%.6g max_rad=%.6g,%.6g,%.6g\n",
                run_name_.c_str(), rms[0], rms[1], rms[2], largest[0], largest[1], largest[2]);
  out_ << text;
}

CommandVerdict RunCoordinator::handle(Controller& c, const PanelCommand& command) {
  CommandVerdict v;
  switch (command.kind) {
    case mb::Command::kStart: {
      if (c.state() != fw::State::kReady || run_active_ || !command.trajectory) {
        v.why = mb::Rejection::kWrongState;
        return v;
      }
      // The Modbus server checked it against the feed-forward in use; a
      // model loaded in between makes the controller refuse it (the walk
      // does not belong in the control loop), and the client starts again.
      const fw::StartResult r = c.start(*command.trajectory);
      if (!r.accepted) {
        v.why = r.wrong_state ? mb::Rejection::kWrongState : mb::Rejection::kTrajectoryLimit;
        v.check = r.check;
        return v;
      }
      const auto names = trajectory_names();
      run_name_ = command.trajectory_id < names.size() ? names[command.trajectory_id] : "?";
      out_ << "delta_fw: running " << run_name_ << " (Modbus)\n";
      ++run_id_;
      run_result_ = mb::RunResult::kRunning;
      run_active_ = true;
      seen_moving_ = false;
      stop_commanded_ = false;
      break;
    }
    case mb::Command::kStop:
      c.stop();  // harmless when nothing runs
      if (run_active_) stop_commanded_ = true;
      break;
    case mb::Command::kFaultReset:
      if (c.state() == fw::State::kFault) {
        if (last_estop_open_) {
          v.why = mb::Rejection::kEStopOpen;
          return v;
        }
        c.reset();
        out_ << "delta_fw: fault reset (Modbus)\n";
      }
      break;
    case mb::Command::kNone:
      break;
  }
  v.accepted = true;
  return v;
}

PanelStatus RunCoordinator::status(const Controller& c, const LinuxHardware& hw) const {
  PanelStatus s;
  s.state = c.state();
  s.fault = c.fault();
  s.cycle = c.cycles();
  const fw::SafetyOutputs& o = hw.last_outputs();
  s.io_bits = static_cast<std::uint16_t>(
      (last_estop_open_ ? mb::kIoEStopOpen : 0) | (o.drive_enable ? mb::kIoDriveEnable : 0) |
      (o.brake_release ? mb::kIoBrakeReleased : 0) | (o.status_ok ? mb::kIoStatusOk : 0) |
      (panel_->log_enabled().load(std::memory_order_relaxed) ? mb::kIoLogEnabled : 0));
  s.run_id = run_id_;
  s.run_result = run_result_;
  s.run_tick = c.run_tick();
  s.run_length = c.run_length_ticks();
  s.log_records = c.log_records();
  s.stale_log_records = c.stale_log_records();
  s.fault_count = fault_count_;
  s.feed_forward = c.feed_forward();
  if (feed_forward_slot_ != nullptr) s.model_fit_id = feed_forward_slot_->fit_id();
  s.fault_history = history_;
  for (unsigned j = 0; j < 3; ++j) {
    s.q_urad[j] = micro(c.feedback()[j].position_rad.raw(), 28);
    s.tau_uNm[j] = micro(c.measured_torque()[j].raw(), 19);
  }
  s.collision_detect = c.collision_config().detect;
  s.collision_count = collision_count_;
  if (c.collided()) {
    const fw::CollisionEvent& e = c.collision();
    s.collision_joint = static_cast<std::uint16_t>(e.joint + 1);
    s.collision_t_ms = collision_t_ms_;
    for (unsigned j = 0; j < 3; ++j) {
      s.collision_residual_uNm[j] = micro(e.residual_Nm[j].raw(), 19);
      s.collision_threshold_uNm[j] = micro(e.threshold_Nm[j].raw(), 19);
    }
  }
  const fw::TrackingStats& t = c.tracking();
  if (t.ticks != 0) {
    s.tracking_run_id = run_id_;
    s.tracking_ticks = t.ticks;
    const auto nano = [](double rad) {
      return static_cast<std::uint32_t>(std::min(std::llround(rad * 1e9), 0xFFFFFFFFll));
    };
    for (unsigned j = 0; j < 3; ++j) {
      s.tracking_rms_nrad[j] =
          nano(std::sqrt(std::ldexp(static_cast<double>(t.sum_sq_rad2_q40[j]), -40) / t.ticks));
      s.tracking_max_nrad[j] = nano(std::ldexp(static_cast<double>(t.max_abs_rad[j].raw()), -28));
    }
  }
  return s;
}

}  // namespace fw_linux
