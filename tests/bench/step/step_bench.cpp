#include "step_bench.hpp"

#include "fw/controller.hpp"
#include "golden_vectors.hpp"

namespace fw::bench {

int last_state = 0;
int last_fault = 0;

namespace {

using delta::fx::Q7_24;

struct FollowingHardware {
  const JointReference* reference = nullptr;
  std::uint32_t logged = 0;
  DriveConfigProgress configure_drives() { return DriveConfigProgress::kDone; }
  void enable_drives(bool) {}
  void quick_stop_drives() {}
  void read_feedback(std::array<DriveFeedback, 3>& fb) {
    for (unsigned j = 0; j < 3; ++j) {
      fb[j].position_rad = reference->q_rad[j];
      fb[j].velocity_rad_s = reference->qd_rad_s[j];
      fb[j].current_A = Q12_19::from(1.5);
      fb[j].fresh = true;
      fb[j].fault = false;
    }
  }
  void command_torque(const std::array<Q12_19, 3>&) {}
  void command_reference(const JointAnglesQ&) {}
  bool estop_open() const { return false; }
  void set_outputs(const SafetyOutputs&) {}
  bool log(const LogRecord&) {
    ++logged;
    return true;
  }
};

ControllerConfig config(FeedForwardMode feed_forward) {
  ControllerConfig c;
  c.geometry = {Q7_24::from(0.20), Q7_24::from(0.46), Q7_24::from(0.10), Q7_24::from(0.035)};
  c.approach_ticks = 1;
  c.feed_forward.mode = feed_forward;
  c.feed_forward.nominal = {Q12_19::from(0.0125), Q12_19::from(0.7026)};
  // Every term, the drive train's too (its division and tanh each tick),
  // and the gearboxes' compliance: the deflection compensation's shift.
  delta::fx::ModelParametersQ model = golden::example_model_parameters();
  model.torque_gain_gap = {Q1_30::from(0.0), Q1_30::from(0.08), Q1_30::from(-0.06)};
  model.load_friction = {Q1_30::from(0.05), Q1_30::from(0.03), Q1_30::from(0.12)};
  model.gearbox_compliance_rad_per_Nm = {Q1_30::from(1.0 / 3000), Q1_30::from(1.0 / 3400),
                                         Q1_30::from(1.0 / 2700)};
  c.feed_forward.model = delta::fx::prepare_model(c.geometry, model);
  // The detector on, with thresholds no run reaches: its work in every step.
  c.collision.detect = true;
  for (unsigned j = 0; j < 3; ++j) {
    c.collision.thresholds.base_Nm[j] = Q12_19::from(1000.0);
    c.collision.thresholds.per_speed_Nm_s_per_rad[j] = Q12_19::from(0.5);
    c.collision.thresholds.per_acceleration_Nm_s2_per_rad[j] = Q12_19::from(0.01);
  }
  return c;
}

TrajectoryConfig pick_and_place() {
  TrajectoryConfig t;
  t.kind = TrajectoryKind::kPickAndPlace;
  auto& p = t.pick_and_place;
  p.waypoints = 3;
  p.points[0] = {Q7_24::from(-0.08), Q7_24::from(0.0), Q7_24::from(-0.48)};
  p.points[1] = {Q7_24::from(0.08), Q7_24::from(0.05), Q7_24::from(-0.42)};
  p.points[2] = {Q7_24::from(0.0), Q7_24::from(-0.08), Q7_24::from(-0.50)};
  p.segment_ticks = 400;
  p.cycles = 4;
  return t;
}

TrajectoryConfig fourier() {
  TrajectoryConfig t;
  t.kind = TrajectoryKind::kFourier;
  auto& f = t.fourier;
  f.base_frequency_mHz = 200;
  f.harmonics = 5;
  f.q0_rad = {Q3_28::from(0.35), Q3_28::from(0.25), Q3_28::from(0.3)};
  for (unsigned j = 0; j < 3; ++j) {
    for (unsigned k = 0; k < 5; ++k) {
      const auto sign = (j + k) % 2 == 0 ? 1 : -1;
      f.sin_amplitude_rad[j][k] = Q3_28::from(0.04).scaled_by(sign);
      f.cos_amplitude_rad[j][k] = Q3_28::from(-0.02).scaled_by(sign);
    }
  }
  f.periods = 2;
  return t;
}

// The measured loop, apart so that callgrind can collect exactly it.
__attribute__((noinline)) std::uint32_t measured_control_steps(Controller<FollowingHardware>& ctl,
                                                               std::uint32_t n,
                                                               void (*after_step)()) {
  std::uint32_t done = 0;
  for (; done < n && ctl.state() == State::kRunning; ++done) {
    ctl.step();
    if (after_step != nullptr) after_step();
  }
  return done;
}

}  // namespace

std::uint32_t run_control_steps(const StepPath& path, std::uint32_t n, const StepMarks& marks) {
  const ControllerConfig cfg = config(path.feed_forward);
  const TrajectoryConfig trajectory =
      path.trajectory == StepTrajectory::kFourier ? fourier() : pick_and_place();
  // The joints rest at the trajectory's first pose.
  JointReference start{};
  Trajectory(cfg.geometry, trajectory).reference(0, start);
  FollowingHardware hw;
  hw.reference = &start;
  Controller<FollowingHardware> ctl(hw, cfg);
  for (int i = 0; i < 3; ++i) ctl.step();  // boot, configure, ready
  if (!ctl.start(trajectory).accepted) return 0;
  ctl.step();  // enters running
  ctl.step();  // the one-tick approach
  hw.reference = &ctl.reference();
  marks.begin();
  const std::uint32_t done = measured_control_steps(ctl, n, marks.after_step);
  marks.end();
  last_state = static_cast<int>(ctl.state());
  last_fault = static_cast<int>(ctl.fault());
  return done;
}

}  // namespace fw::bench
