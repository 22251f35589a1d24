// The controller: a state machine and the control loop, driven by step()
// once per tick. A template over the hardware (fw/hardware.hpp), so that the
// same code runs on Linux, on Cortex-M and against the tests' fakes.
//
//   boot -> configuring -> ready -> running -> stopping -> ready
//   any fault (e-stop, drive fault, lost feedback, limit, tracking error,
//   configuration failure, log overflow, collision) -> fault; drives stay
//   disabled and braked there until reset(), which starts again at boot. A
//   collision quick-stops the drives (CiA 402) instead of disabling them.
#pragma once

#include <array>
#include <cstdint>

#include "delta/fixed/math.hpp"
#include "fw/collision.hpp"
#include "fw/deflection.hpp"
#include "fw/faults.hpp"
#include "fw/feed_forward.hpp"
#include "fw/hardware.hpp"
#include "fw/joint_controller.hpp"
#include "fw/torque_from_current.hpp"
#include "fw/tracking.hpp"
#include "fw/trajectory.hpp"

namespace fw {

using delta::controller::State;
using delta::controller::state_name;

struct ControllerConfig {
  GeometryQ geometry{};
  std::uint32_t tick_period_us{1000};
  JointLimits limits{};
  JointGains gains{};
  FeedForwardConfig feed_forward{};
  CollisionConfig collision{};
  std::array<JointTorqueConfig, 3> torque{};
  Q3_28 max_tracking_error_rad{Q3_28::from(0.1)};
  std::uint32_t approach_ticks{1000};  // move from rest to the trajectory's start
  std::uint32_t stop_ticks{200};       // hold still before disabling
  std::uint32_t configure_timeout_ticks{5000};
  std::uint32_t lost_feedback_ticks{3};  // consecutive cycles without fresh feedback
};

// What a trajectory must be checked against to run on a controller so
// configured.
inline TrajectoryBounds trajectory_bounds(const ControllerConfig& c) {
  return {c.geometry, c.limits, c.feed_forward, c.gains.max_torque_Nm};
}

// Why start() refused, if it did.
struct StartResult {
  bool accepted{false};
  TrajectoryCheck check{};
  bool wrong_state{false};
};

template <class Hardware>
class Controller {
 public:
  Controller(Hardware& hw, const ControllerConfig& config)
      : hw_(hw),
        config_(config),
        joint_(config.gains, config.tick_period_us),
        torque_from_current_{TorqueFromCurrent(config.torque[0]),
                             TorqueFromCurrent(config.torque[1]),
                             TorqueFromCurrent(config.torque[2])},
        trajectory_(config.geometry, TrajectoryConfig{}),
        ticks_per_s_(1000000u / config.tick_period_us) {}

  // Checks the whole trajectory against the limits and the feed-forward's
  // torques (before any motion, in the caller's context, not in step()) and
  // arms it.
  StartResult start(const TrajectoryConfig& trajectory) {
    if (state_ != State::kReady) return wrong_state();
    return start(CheckedTrajectory::check(bounds(), trajectory));
  }
  // Arms a trajectory checked elsewhere, against this controller's bounds
  // (a check against others, such as another feed-forward model, is
  // refused as kInvalidConfig).
  StartResult start(const CheckedTrajectory& trajectory) {
    if (state_ != State::kReady) return wrong_state();
    StartResult r;
    r.check = trajectory.result();
    if (!trajectory.ok()) return r;
    if (!trajectory.checked_against(bounds())) {
      r.check = TrajectoryCheck{TrajectoryFault::kInvalidConfig, 0, -1};
      return r;
    }
    trajectory_ = Trajectory(config_.geometry, trajectory.config());
    start_requested_ = true;
    r.accepted = true;
    return r;
  }
  // What a trajectory must be checked against to run here.
  TrajectoryBounds bounds() const { return trajectory_bounds(config_); }
  // Changes the feed-forward between runs: refused (false) while a run is
  // on (running, stopping, or a start requested), and for a model mode
  // without a model or with a model fitted for another geometry.
  bool set_feed_forward(const FeedForwardConfig& f) {
    if (state_ == State::kRunning || state_ == State::kStopping || start_requested_) return false;
    if (f.mode == FeedForwardMode::kModel &&
        (f.model.parameters.kind == ModelKind::kNone || !(f.model.geometry == config_.geometry))) {
      return false;
    }
    config_.feed_forward = f;
    return true;
  }
  const FeedForwardConfig& feed_forward() const { return config_.feed_forward; }
  void stop() { stop_requested_ = true; }
  void reset() { reset_requested_ = true; }

  // One control cycle.
  void step() {
    hw_.read_feedback(feedback_);
    // The e-stop is read every cycle (its debouncing needs the samples), and
    // it and the drive faults are checked first in every state, so the
    // drives are disabled within the cycle that sees them.
    const bool estop_open = hw_.estop_open();
    if (state_ != State::kFault) {
      if (estop_open) {
        enter_fault(Fault::kEStop);
      } else if (state_ == State::kRunning || state_ == State::kStopping ||
                 state_ == State::kReady) {
        supervise_drives();
      }
    }
    switch (state_) {
      case State::kBoot:
        state_ = State::kConfiguring;
        state_ticks_ = 0;
        break;
      case State::kConfiguring:
        configure();
        break;
      case State::kReady:
        if (start_requested_) begin_run();
        break;
      case State::kRunning:
      case State::kStopping:
        control();
        break;
      case State::kFault:
        if (reset_requested_ && !estop_open) {
          fault_ = Fault::kNone;
          state_ = State::kBoot;
        }
        break;
    }
    start_requested_ = state_ == State::kReady && start_requested_;
    stop_requested_ = false;
    reset_requested_ = false;
    apply_outputs();
    ++cycles_;
    ++state_ticks_;
  }

  State state() const { return state_; }
  Fault fault() const { return fault_; }
  std::uint32_t cycles() const { return cycles_; }
  std::uint32_t run_tick() const { return run_tick_; }
  const JointReference& reference() const { return reference_; }
  // The tracking error of the current or last run's trajectory (after the
  // approach); reset when a run starts.
  const TrackingStats& tracking() const { return tracking_; }
  const std::array<Q12_19, 3>& measured_torque() const { return measured_torque_; }
  const std::array<Q12_19, 3>& commanded_torque() const { return command_; }
  // The run's length in cycles (the approach, then the trajectory's ticks
  // 0..length: run_tick() ends equal to it), and log records so far.
  std::uint32_t run_length_ticks() const {
    return config_.approach_ticks + trajectory_.length_ticks() + 1;
  }
  std::uint32_t log_records() const { return log_seq_; }
  // Of those, records marked stale (a drive's feedback missed the cycle).
  std::uint32_t stale_log_records() const { return stale_log_records_; }
  const std::array<DriveFeedback, 3>& feedback() const { return feedback_; }
  // The last collision since boot (its run tick: run_tick() then), if any.
  bool collided() const { return collided_; }
  const CollisionEvent& collision() const { return collision_; }
  std::uint32_t collision_run_tick() const { return collision_run_tick_; }
  const CollisionConfig& collision_config() const { return config_.collision; }
  // The detector's filtered residuals at the last tick it ran.
  const std::array<Q12_19, 3>& collision_residual() const { return detector_.residual_Nm(); }
  // Changes the detector's settings between runs (refused during one).
  bool set_collision(const CollisionConfig& c) {
    if (state_ == State::kRunning || state_ == State::kStopping || start_requested_) return false;
    config_.collision = c;
    return true;
  }

 private:
  static StartResult wrong_state() {
    StartResult r;
    r.wrong_state = true;
    return r;
  }

  void enter_fault(Fault f) {
    if (state_ != State::kFault) fault_ = f;
    state_ = State::kFault;
    command_ = {};
    hw_.command_torque(command_);
    if (f == Fault::kCollision) {
      hw_.quick_stop_drives();
    } else {
      hw_.enable_drives(false);
    }
    joint_.reset();
  }

  // A drive fault, a malformed frame or a bus error faults at once; feedback
  // missing (or late) for lost_feedback_ticks cycles in a row faults then,
  // as late when the last missing sample did arrive, after the deadline.
  void supervise_drives() {
    bool all_fresh = true;
    for (unsigned j = 0; j < 3; ++j) {
      const DriveFeedback& f = feedback_[j];
      if (f.fault) return enter_fault(Fault::kDriveFault);
      if (f.problem == FeedbackProblem::kMalformed) return enter_fault(Fault::kFeedbackMalformed);
      if (f.problem == FeedbackProblem::kBusError) return enter_fault(Fault::kCanBusError);
      if (!f.fresh) last_stale_was_late_ = f.problem == FeedbackProblem::kLate;
      all_fresh = all_fresh && f.fresh;
    }
    feedback_fresh_ = all_fresh;
    stale_cycles_ = all_fresh ? 0 : stale_cycles_ + 1;
    if (stale_cycles_ >= config_.lost_feedback_ticks) {
      enter_fault(last_stale_was_late_ ? Fault::kFeedbackLate : Fault::kHeartbeatLost);
    }
  }

  void configure() {
    switch (hw_.configure_drives()) {
      case DriveConfigProgress::kDone:
        state_ = State::kReady;
        state_ticks_ = 0;
        break;
      case DriveConfigProgress::kFailed:
        enter_fault(Fault::kDriveConfigFailed);
        break;
      case DriveConfigProgress::kInProgress:
        if (state_ticks_ >= config_.configure_timeout_ticks) enter_fault(Fault::kDriveConfigFailed);
        break;
    }
  }

  void begin_run() {
    start_requested_ = false;
    for (unsigned j = 0; j < 3; ++j) approach_from_[j] = feedback_[j].position_rad;
    run_tick_ = 0;
    tracking_ = {};
    joint_.reset();
    detector_.reset();
    deflection_.reset();
    compensate_ = compensates_deflection(config_.feed_forward);  // the run's
    if (compensate_) start_at_the_arm();
    hw_.enable_drives(true);
    state_ = State::kRunning;
    state_ticks_ = 0;
  }

  // The reference: an approach from rest to the trajectory's first point,
  // then the trajectory; while stopping, the last reference held still.
  bool next_reference() {
    if (state_ == State::kStopping) {
      reference_.qd_rad_s = {};
      reference_.qdd_rad_s2 = {};
      return true;
    }
    const std::uint32_t approach = config_.approach_ticks;
    if (run_tick_ < approach) {
      JointReference start;
      if (trajectory_.reference(0, start) != KinematicsStatus::kOk) return false;
      approach_reference(start);
      return true;
    }
    // The platform's position and acceleration only for the model.
    const bool model = config_.feed_forward.mode == FeedForwardMode::kModel;
    return trajectory_.reference(run_tick_ - approach, reference_, model) == KinematicsStatus::kOk;
  }

  // With deflection compensation the approach starts where the arms are,
  // the motors' angles less the deflection of the torque that holds them
  // still there (the model's), so that the motors' reference starts where
  // they are.
  void start_at_the_arm() {
    JointReference rest;
    rest.q_rad = approach_from_;
    Joint3Q12_19 tau{};
    if (feed_forward_torque(config_.feed_forward, rest, tau) != KinematicsStatus::kOk) return;
    const auto& c = config_.feed_forward.model.parameters.gearbox_compliance_rad_per_Nm;
    for (unsigned j = 0; j < 3; ++j) approach_from_[j] = arm_angle(c[j], tau[j], approach_from_[j]);
  }

  // Minimum-jerk joint move from approach_from_ to start over approach_ticks.
  void approach_reference(const JointReference& start) {
    using delta::fx::mul;
    const MinJerk mj = min_jerk(delta::fx::ratio(run_tick_, config_.approach_ticks));
    const Q1_30 w = mj.w;
    const Q1_30 dw = mj.dw;
    const std::int64_t approach_us = std::int64_t{config_.approach_ticks} * config_.tick_period_us;
    reference_.platform_known = false;  // a joint-space move
    for (unsigned j = 0; j < 3; ++j) {
      const Q3_28 span = start.q_rad[j] - approach_from_[j];
      reference_.q_rad[j] = approach_from_[j] + mul<Q3_28>(w, span);
      const std::int64_t v = delta::fx::shift_round(
          std::int64_t{mul<Q3_28>(dw, span).raw()} * 1000000 / approach_us, 7);
      reference_.qd_rad_s[j] = Q10_21::from_raw(delta::fx::saturate32(v));
      reference_.qdd_rad_s2[j] = {};  // the feedback tracks the small approach accelerations
    }
  }

  void control() {
    if (stop_requested_ && state_ == State::kRunning) {
      state_ = State::kStopping;
      state_ticks_ = 0;
    }
    if (!next_reference()) {
      enter_fault(Fault::kTrajectoryRejected);
      return;
    }
    Joint3Q12_19 feed_forward{};
    if (feed_forward_torque(config_.feed_forward, reference_, feed_forward) !=
        KinematicsStatus::kOk) {
      enter_fault(Fault::kTrajectoryRejected);
      return;
    }
    // What the motors track: the reference, or past it by the deflection.
    JointReference motor = reference_;
    if (compensate_) {
      // A stop holds the reference still at once: the shift's step (the
      // inertia the model no longer sees) is no motion to follow.
      deflection_.shift(config_.feed_forward.model.parameters.gearbox_compliance_rad_per_Nm,
                        feed_forward, ticks_per_s_, state_ != State::kStopping, motor);
    }
    JointAnglesQ q{};
    std::array<Q10_21, 3> qd{};
    if (!read_joints(motor, q, qd)) return;
    if (state_ == State::kRunning && run_tick_ >= config_.approach_ticks) {
      tracking_.add(motor.q_rad, q);
    }
    if (collision_detected(feed_forward)) return;
    std::array<bool, 3> saturated{};
    command_ = joint_.update(motor, q, qd, feed_forward, saturated);
    hw_.command_torque(command_);
    hw_.command_reference(reference_.q_rad);
    if (!log_tick(q)) return;
    advance_run();
  }

  // The detector, on the trajectory and while stopping (not in the
  // approach, whose reference carries no acceleration): true after
  // entering the collision fault.
  bool collision_detected(const Joint3Q12_19& model_Nm) {
    if (!config_.collision.detect) return false;
    if (state_ == State::kRunning && run_tick_ < config_.approach_ticks) return false;
    if (!detector_.update(config_.collision, measured_torque_, model_Nm, reference_.qd_rad_s,
                          reference_.qdd_rad_s2, collision_)) {
      return false;
    }
    collided_ = true;
    collision_run_tick_ = run_tick_;
    enter_fault(Fault::kCollision);
    return true;
  }

  // The joints' angles and velocities from the feedback, checked against
  // the limits and the tracking error from the motors' reference `motor`,
  // and their measured torques; false after entering the fault a check
  // gives.
  bool read_joints(const JointReference& motor, JointAnglesQ& q, std::array<Q10_21, 3>& qd) {
    for (unsigned j = 0; j < 3; ++j) {
      q[j] = feedback_[j].position_rad;
      qd[j] = feedback_[j].velocity_rad_s;
      if (q[j] < config_.limits.min_rad || q[j] > config_.limits.max_rad) {
        enter_fault(Fault::kJointLimit);
        return false;
      }
      if (delta::fx::abs(qd[j]) > config_.limits.max_velocity_rad_s) {
        enter_fault(Fault::kVelocityLimit);
        return false;
      }
      if (delta::fx::abs(motor.q_rad[j] - q[j]) > config_.max_tracking_error_rad) {
        enter_fault(Fault::kTrackingError);
        return false;
      }
      measured_torque_[j] = torque_from_current_[j](feedback_[j].current_A);
    }
    return true;
  }

  // This tick's log record; false after a log overflow fault.
  bool log_tick(const JointAnglesQ& q) {
    LogRecord rec;
    rec.seq = log_seq_++;
    rec.q_rad = q;
    rec.tau_Nm = measured_torque_;
    for (unsigned j = 0; j < 3; ++j) rec.qa_rad[j] = feedback_[j].arm_position_rad;
    rec.stale = !feedback_fresh_;
    if (rec.stale) ++stale_log_records_;
    if (!hw_.log(rec)) {
      enter_fault(Fault::kLogOverflow);
      return false;
    }
    return true;
  }

  // The run's next tick: stopping after its last, ready after the stop.
  void advance_run() {
    if (state_ == State::kRunning) {
      ++run_tick_;
      if (run_tick_ > config_.approach_ticks + trajectory_.length_ticks()) {
        state_ = State::kStopping;
        state_ticks_ = 0;
      }
    } else if (state_ticks_ >= config_.stop_ticks) {
      command_ = {};
      hw_.command_torque(command_);
      hw_.enable_drives(false);
      state_ = State::kReady;
      state_ticks_ = 0;
    }
  }

  void apply_outputs() {
    const bool moving = state_ == State::kRunning || state_ == State::kStopping;
    hw_.set_outputs(SafetyOutputs{moving, moving, state_ != State::kFault});
  }

  Hardware& hw_;
  ControllerConfig config_;
  JointController joint_;
  std::array<TorqueFromCurrent, 3> torque_from_current_;
  Trajectory trajectory_;
  State state_{State::kBoot};
  Fault fault_{Fault::kNone};
  std::array<DriveFeedback, 3> feedback_{};
  JointReference reference_{};
  TrackingStats tracking_{};
  JointAnglesQ approach_from_{};
  std::array<Q12_19, 3> measured_torque_{};
  std::array<Q12_19, 3> command_{};
  CollisionDetector detector_{};
  DeflectionCompensation deflection_{};
  bool compensate_{false};  // this run's feed-forward compensates the deflection
  std::uint32_t ticks_per_s_;
  CollisionEvent collision_{};
  std::uint32_t collision_run_tick_{0};
  bool collided_{false};
  std::uint32_t cycles_{0};
  std::uint32_t state_ticks_{0};
  std::uint32_t run_tick_{0};
  std::uint32_t stale_cycles_{0};
  std::uint32_t log_seq_{0};
  std::uint32_t stale_log_records_{0};
  bool feedback_fresh_{true};
  bool last_stale_was_late_{false};
  bool start_requested_{false};
  bool stop_requested_{false};
  bool reset_requested_{false};
};

}  // namespace fw
