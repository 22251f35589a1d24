// The controller's state machine and control loop against a fake of the
// hardware interface, closed around the shared lumped model of the delta
// (common/model/include/delta/dynamics.hpp) as the plant: software in the loop.
#include "fw/controller.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "delta/dynamics.hpp"
#include "delta/q_conversion.hpp"
#include "host_id/identify.hpp"

namespace fw {
namespace {

using delta::to_double;
using delta::to_q_saturated;
using delta::fx::Q7_24;

// The simulated delta: forward dynamics integrated with RK4 over sub-steps.
struct Plant {
  delta::Geometry geometry = delta::kDefaultGeometry;
  delta::LumpedParameters params = delta::default_lumped_parameters();
  delta::Joint3 q{0.45, 0.45, 0.45};
  delta::Joint3 qd{};
  bool stuck = false;  // a jammed joint 1 for the tracking-error test

  void advance(const delta::Joint3& tau, double dt) {
    // Four RK4 sub-steps; a jammed joint 1 is held still after each.
    for (int i = 0; i < 4; ++i) {
      ASSERT_EQ(delta::integrate_rk4(geometry, params, tau, dt / 4, 1, q, qd),
                delta::KinematicsStatus::kOk);
      if (stuck) qd[0] = 0.0;
    }
  }
};

// A fake of the hardware interface: ideal drives in torque mode on the plant,
// with injectable faults; it records what the core did.
struct FakeHardware {
  Plant plant;
  ControllerConfig* config = nullptr;
  int configure_calls_until_done = 3;
  bool configure_fails = false;
  bool drives_enabled = false;
  bool quick_stopped = false;
  int drives_disabled_at_cycle = -1;
  int cycle = 0;
  std::array<Q12_19, 3> torque{};
  JointAnglesQ reference{};  // the arms' reference of the last controlled tick
  bool estop = false;
  bool drive_fault = false;
  bool stale_feedback = false;
  FeedbackProblem problem_on_joint2 = FeedbackProblem::kNone;
  double position_offset_rad = 0.0;  // joint 1 reads off by this much
  double velocity_offset_rad_s = 0.0;
  std::size_t log_capacity = 1000000;
  std::vector<LogRecord> log_records;
  std::vector<std::array<Q12_19, 3>> torque_behind_current;  // per record
  std::array<Q12_19, 3> torque_at_feedback{};
  SafetyOutputs outputs;
  delta::Joint3 external_Nm{};  // a contact's torque at the joints, on the plant alone
  static constexpr double kEncoderStep = 2.0 * std::numbers::pi / 131072.0;  // 17 bits

  DriveConfigProgress configure_drives() {
    if (configure_fails) return DriveConfigProgress::kFailed;
    return --configure_calls_until_done <= 0 ? DriveConfigProgress::kDone
                                             : DriveConfigProgress::kInProgress;
  }
  void enable_drives(bool on) {
    if (drives_enabled && !on) drives_disabled_at_cycle = cycle;
    drives_enabled = on;
    quick_stopped = false;
  }
  void quick_stop_drives() {
    enable_drives(false);
    quick_stopped = true;
  }
  void read_feedback(std::array<DriveFeedback, 3>& fb) {
    torque_at_feedback = drives_enabled ? torque : std::array<Q12_19, 3>{};
    for (unsigned j = 0; j < 3; ++j) {
      const double q = std::round(plant.q[j] / kEncoderStep) * kEncoderStep +
                       (j == 0 ? position_offset_rad : 0.0);
      fb[j].position_rad = to_q_saturated<Q3_28>(q);
      fb[j].velocity_rad_s =
          to_q_saturated<Q10_21>(plant.qd[j] + (j == 0 ? velocity_offset_rad_s : 0.0));
      fb[j].current_A =
          current_from_torque(config->torque[j], drives_enabled ? torque[j] : Q12_19::zero());
      fb[j].problem = j == 1 ? problem_on_joint2 : FeedbackProblem::kNone;
      fb[j].fresh = !stale_feedback && fb[j].problem != FeedbackProblem::kLate;
      fb[j].fault = drive_fault && j == 1;
    }
  }
  void command_torque(const std::array<Q12_19, 3>& t) { torque = t; }
  void command_reference(const JointAnglesQ& q) { reference = q; }
  bool estop_open() const { return estop; }
  void set_outputs(const SafetyOutputs& o) { outputs = o; }
  bool log(const LogRecord& r) {
    if (log_records.size() >= log_capacity) return false;
    log_records.push_back(r);
    torque_behind_current.push_back(torque_at_feedback);
    return true;
  }
  // The plant moves under the applied torque for one tick; braked when disabled.
  void physics(double dt) {
    ++cycle;
    if (!drives_enabled) {
      plant.qd = {};
      return;
    }
    delta::Joint3 tau{};
    for (unsigned j = 0; j < 3; ++j) tau[j] = to_double(torque[j]) + external_Nm[j];
    plant.advance(tau, dt);
  }
};

ControllerConfig default_config() {
  ControllerConfig c;
  const delta::Geometry g = delta::kDefaultGeometry;
  c.geometry = {to_q_saturated<Q7_24>(g.upper_arm_length_m),
                to_q_saturated<Q7_24>(g.forearm_length_m), to_q_saturated<Q7_24>(g.base_radius_m),
                to_q_saturated<Q7_24>(g.platform_radius_m)};
  // Nominal feed-forward: the arm plus a third of the platform at the elbow.
  c.feed_forward.nominal.arm_inertia_kg_m2 = Q12_19::from(0.0072 + 0.40 * 0.04 / 3.0);
  c.feed_forward.nominal.gravity_moment_Nm = Q12_19::from(0.441 + 0.40 * 9.81 * 0.2 / 3.0);
  for (auto& t : c.torque) {
    t.gear_ratio = Q12_19::from(9.0);
    t.torque_constant_Nm_per_A = Q7_24::from(0.08);
    t.efficiency = Q1_30::from(0.95);
  }
  return c;
}

TrajectoryConfig excitation() {
  TrajectoryConfig c;
  c.blend_ticks = 1000;
  auto& f = c.fourier;
  f.base_frequency_mHz = 200;
  f.harmonics = 4;
  f.periods = 2;
  f.q0_rad = {to_q_saturated<Q3_28>(0.45), to_q_saturated<Q3_28>(0.45),
              to_q_saturated<Q3_28>(0.45)};
  const double a[3][4][2] = {{{0.12, 0.05}, {-0.05, 0.04}, {0.03, -0.02}, {0.01, 0.01}},
                             {{-0.1, 0.07}, {0.06, 0.02}, {-0.02, 0.03}, {0.01, -0.01}},
                             {{0.09, -0.1}, {0.04, -0.04}, {0.02, 0.01}, {-0.01, 0.01}}};
  for (unsigned j = 0; j < 3; ++j) {
    for (unsigned k = 0; k < 4; ++k) {
      f.sin_amplitude_rad[j][k] = to_q_saturated<Q3_28>(a[j][k][0]);
      f.cos_amplitude_rad[j][k] = to_q_saturated<Q3_28>(a[j][k][1]);
    }
  }
  return c;
}

// A run to its end, its tracking error measured in double from the
// plant: the worst over every cycle, and on the trajectory (after the
// approach) the sums of squares and the largest, as the controller's own
// integer statistics count them.
struct TrackingInDouble {
  double worst{0.0};
  int cycles{0};
  std::array<double, 3> sum_sq{}, largest{};
  int trajectory_ticks{0};
};

class ControllerTest : public ::testing::Test {
 protected:
  ControllerConfig config = default_config();
  FakeHardware hw;
  Controller<FakeHardware> ctl{hw, config};

  void SetUp() override { hw.config = &config; }
  void tick(int n = 1) {
    for (int i = 0; i < n; ++i) {
      ctl.step();
      hw.physics(1e-3);
    }
  }
  void to_ready() {
    tick(5);
    ASSERT_EQ(ctl.state(), State::kReady);
  }
  void to_running() {
    to_ready();
    ASSERT_TRUE(ctl.start(excitation()).accepted);
    tick(1);
    ASSERT_EQ(ctl.state(), State::kRunning);
  }
  void expect_fault(Fault f) {
    EXPECT_EQ(ctl.state(), State::kFault);
    EXPECT_EQ(ctl.fault(), f) << fault_name(ctl.fault());
    EXPECT_FALSE(hw.drives_enabled);
    EXPECT_FALSE(hw.outputs.drive_enable);
    EXPECT_FALSE(hw.outputs.brake_release);  // braked
    EXPECT_FALSE(hw.outputs.status_ok);
    for (const auto& t : hw.torque) EXPECT_EQ(t.raw(), 0);
  }

  // A run to its end, its tracking error measured in double from the plant.
  TrackingInDouble run_tracking_in_double() {
    TrackingInDouble d;
    while (ctl.state() == State::kRunning && d.cycles < 20000) {
      const bool on_trajectory = ctl.run_tick() >= config.approach_ticks;
      const std::array<double, 3> q_seen = hw.plant.q;  // what this tick's feedback carries
      tick();
      ++d.cycles;
      for (unsigned j = 0; j < 3; ++j) {
        const double e = to_double(ctl.reference().q_rad[j]) - q_seen[j];
        d.worst = std::max(d.worst, std::abs(e));
        if (on_trajectory && ctl.state() == State::kRunning) {
          d.sum_sq[j] += e * e;
          d.largest[j] = std::max(d.largest[j], std::abs(e));
        }
      }
      d.trajectory_ticks += on_trajectory && ctl.state() == State::kRunning;
    }
    return d;
  }

  // One record per control cycle, numbered without gaps; the logged torque
  // is the torque from the measured current, which the drive produced for
  // the previous command: current and back agree to 2e-5.
  void expect_every_cycle_logged_with_its_torque() {
    ASSERT_GT(hw.log_records.size(), 13000u);
    for (std::size_t i = 0; i < hw.log_records.size(); ++i) {
      EXPECT_EQ(hw.log_records[i].seq, i);
      EXPECT_FALSE(hw.log_records[i].stale);
    }
    EXPECT_EQ(ctl.stale_log_records(), 0u);
    double worst_tau = 0.0;
    for (std::size_t i = 0; i < hw.log_records.size(); ++i) {
      for (unsigned j = 0; j < 3; ++j) {
        worst_tau = std::max(worst_tau, std::abs(to_double(hw.log_records[i].tau_Nm[j]) -
                                                 to_double(hw.torque_behind_current[i][j])));
      }
    }
    EXPECT_LT(worst_tau, 2e-5);
    EXPECT_GT(std::abs(to_double(hw.log_records[5000].tau_Nm[0])), 0.1);  // a real torque, not zero
  }
};

// The controller's integer tracking statistics against the same measured
// in double.
void expect_tracking_stats_match(const fw::TrackingStats& t, const TrackingInDouble& d) {
  EXPECT_NEAR(static_cast<int>(t.ticks), d.trajectory_ticks, 2);
  for (unsigned j = 0; j < 3; ++j) {
    const double rms = std::sqrt(std::ldexp(static_cast<double>(t.sum_sq_rad2_q40[j]), -40) /
                                 static_cast<double>(t.ticks));
    const double rms_double = std::sqrt(d.sum_sq[j] / d.trajectory_ticks);
    std::printf("joint %u tracking: rms %.4g rad (double from the plant %.4g), max %.4g (%.4g)\n",
                j, rms, rms_double, to_double(t.max_abs_rad[j]), d.largest[j]);
    EXPECT_NEAR(rms, rms_double, 0.05 * rms_double + 2e-6) << j;  // encoder quantisation apart
    EXPECT_NEAR(to_double(t.max_abs_rad[j]), d.largest[j], 0.1 * d.largest[j] + 1e-5) << j;
    EXPECT_GT(rms, 1e-6) << "a run without any error is not this plant";
  }
}

TEST_F(ControllerTest, BootsConfiguresAndWaitsReadyWithDrivesOffAndBraked) {
  tick(1);
  EXPECT_EQ(ctl.state(), State::kConfiguring);
  tick(4);
  EXPECT_EQ(ctl.state(), State::kReady);
  EXPECT_FALSE(hw.drives_enabled);
  EXPECT_FALSE(hw.outputs.brake_release);
  EXPECT_TRUE(hw.outputs.status_ok);
}

TEST_F(ControllerTest, SoftwareInTheLoopExcitationTracksAndLogsEveryCycle) {
  to_running();
  EXPECT_TRUE(hw.outputs.drive_enable);
  EXPECT_TRUE(hw.outputs.brake_release);
  const TrackingInDouble d = run_tracking_in_double();
  expect_tracking_stats_match(ctl.tracking(), d);
  // approach (1000) + blends (2000) + 2 periods of 5 s (10000), then stopping.
  EXPECT_EQ(ctl.state(), State::kStopping);
  EXPECT_NEAR(d.cycles, 13001, 2);
  std::printf("SIL tracking error: worst %.3g rad over %d cycles\n", d.worst, d.cycles);
  EXPECT_LT(d.worst, 0.01);
  tick(static_cast<int>(config.stop_ticks) + 1);
  EXPECT_EQ(ctl.state(), State::kReady);
  EXPECT_FALSE(hw.drives_enabled);
  expect_every_cycle_logged_with_its_torque();
}

// The tracking statistics' integer arithmetic: errors rounded to 2^-20 rad
// and squared, the largest kept in Q3.28, a sum that would wrap held at
// its largest value, an error past 8 rad counted as 8 rad.
TEST(TrackingStatsTest, SumsSquaresInQ3_20AndKeepsTheLargestError) {
  using delta::fx::Q3_28;
  fw::TrackingStats t;
  const delta::fx::JointAnglesQ zero{};
  const delta::fx::JointAnglesQ q{Q3_28::from_raw(-268435), Q3_28::from_raw(256),
                                  Q3_28::from_raw(0)};  // -0.001 rad, 2^-20 rad, 0
  t.add(zero, q);
  t.add(zero, q);
  EXPECT_EQ(t.ticks, 2u);
  EXPECT_EQ(t.sum_sq_rad2_q40[0], 2u * 1049u * 1049u);  // 268435 / 256 = 1048.57 -> 1049
  EXPECT_EQ(t.sum_sq_rad2_q40[1], 2u);
  EXPECT_EQ(t.sum_sq_rad2_q40[2], 0u);
  EXPECT_EQ(t.max_abs_rad[0].raw(), 268435);
  t.sum_sq_rad2_q40[1] = UINT64_MAX - 1;
  t.add(zero, q);
  EXPECT_EQ(t.sum_sq_rad2_q40[1], UINT64_MAX);
  // An error past Q3.28's range (from -7 rad to +7 rad) counts as 8 rad.
  fw::TrackingStats far;
  const delta::fx::JointAnglesQ low{Q3_28::from(-7.0), Q3_28::zero(), Q3_28::zero()};
  const delta::fx::JointAnglesQ high{Q3_28::from(7.0), Q3_28::zero(), Q3_28::zero()};
  far.add(high, low);
  far.add(low, high);
  EXPECT_EQ(far.max_abs_rad[0].raw(), INT32_MAX);
  EXPECT_EQ(far.sum_sq_rad2_q40[0], 2u * (std::uint64_t{1} << 23) * (std::uint64_t{1} << 23));
}

TEST_F(ControllerTest, TheCoreLogOfAnExcitationIdentifiesThePlant) {
  // The firmware core drives the simulated delta; its log records (seq, q,
  // tau from current) become a delta-log and host_id fits them: the chain
  // without the bus, against the plant's true parameters.
  to_running();
  while (ctl.state() == State::kRunning) tick();
  host_id::DeltaLog log;
  log.name = "sil";
  log.geometry = delta::kDefaultGeometry;
  log.sample_rate_hz = 1000.0;
  for (std::size_t i = 0; i < hw.log_records.size(); ++i) {
    const LogRecord& r = hw.log_records[i];
    log.t.push_back(static_cast<double>(r.seq) * 1e-3);
    log.seq.push_back(r.seq);
    for (unsigned j = 0; j < 3; ++j) {
      log.q[j].push_back(to_double(r.q_rad[j]));
      log.tau[j].push_back(to_double(r.tau_Nm[j]));
    }
  }
  host_id::FitOptions f;
  f.method = host_id::Method::kLeastSquares;
  f.model.name = "lumped";  // the plant's own model
  const host_id::FitResult r = host_id::fit_log(log, f);
  const auto truth = host_id::parameter_vector(f.model, delta::default_lumped_parameters());
  for (std::size_t i = 0; i < truth.size(); ++i) {
    EXPECT_NEAR(r.parameters[i].value, truth[i], 0.03 * truth[i]) << r.parameters[i].info.name;
  }
}

TEST_F(ControllerTest, StopCommandHoldsThenDisables) {
  to_running();
  tick(500);
  ctl.stop();
  tick(1);
  EXPECT_EQ(ctl.state(), State::kStopping);
  EXPECT_TRUE(hw.drives_enabled);
  tick(static_cast<int>(config.stop_ticks));
  EXPECT_EQ(ctl.state(), State::kReady);
  EXPECT_FALSE(hw.drives_enabled);
}

TEST_F(ControllerTest, StartIsRefusedOutsideReadyOrForATrajectoryThatBreaksALimit) {
  tick(1);
  EXPECT_TRUE(ctl.start(excitation()).wrong_state);
  to_ready();
  TrajectoryConfig far = excitation();
  far.fourier.sin_amplitude_rad[1][0] = to_q_saturated<Q3_28>(1.5);
  const StartResult r = ctl.start(far);
  EXPECT_FALSE(r.accepted);
  EXPECT_NE(r.check.fault, TrajectoryFault::kOk);
  tick(3);
  EXPECT_EQ(ctl.state(), State::kReady);
  EXPECT_FALSE(hw.drives_enabled);
}

// The plant's lumped truth as the controller's model parameters: arms and
// platform, and with `friction` the joints' friction too.
delta::fx::ModelParametersQ lumped_truth_q(bool friction) {
  delta::fx::ModelParametersQ m;
  m.kind = ModelKind::kLumped;
  const delta::LumpedParameters truth = delta::default_lumped_parameters();
  for (unsigned j = 0; j < 3; ++j) {
    m.arm_inertia_kg_m2[j] = to_q_saturated<Q7_24>(truth.arm_inertia_kg_m2[j]);
    m.arm_gravity_cos_Nm[j] = to_q_saturated<Q12_19>(truth.arm_gravity_moment_Nm[j]);
    if (!friction) continue;
    m.viscous_friction_Nm_s_per_rad[j] =
        to_q_saturated<Q12_19>(truth.viscous_friction_Nm_s_per_rad[j]);
    m.coulomb_friction_Nm[j] = to_q_saturated<Q12_19>(truth.coulomb_friction_Nm[j]);
  }
  m.coulomb_smoothing_rad_s = to_q_saturated<Q10_21>(truth.coulomb_smoothing_rad_s);
  m.platform_inertial_mass_kg = to_q_saturated<Q7_24>(truth.platform_mass_kg);
  m.platform_weight_mass_kg = to_q_saturated<Q7_24>(truth.platform_mass_kg);
  return m;
}

// The feed-forward changes only between runs, only to a model fitted for
// this geometry; a trajectory checked before the change is refused at
// start (its check no longer covers the feed-forward), and a feed-forward
// that would ask for more than the max torque refuses the trajectory at its
// check, naming the tick and the joint.
TEST_F(ControllerTest, TheFeedForwardChangesBetweenRunsAndIsCheckedWithTheTrajectory) {
  to_ready();
  const delta::fx::ModelParametersQ m = lumped_truth_q(false);
  FeedForwardConfig model = ctl.feed_forward();
  model.mode = FeedForwardMode::kModel;
  GeometryQ other = config.geometry;
  other.upper_arm_length_m = to_q_saturated<Q7_24>(0.25);
  model.model = delta::fx::prepare_model(other, m);
  EXPECT_FALSE(ctl.set_feed_forward(model));  // fitted for another robot
  FeedForwardConfig empty = model;
  empty.model = {};
  EXPECT_FALSE(ctl.set_feed_forward(empty));  // no model
  model.model = delta::fx::prepare_model(config.geometry, m);

  const CheckedTrajectory before = CheckedTrajectory::check(ctl.bounds(), excitation());
  ASSERT_TRUE(before.ok());
  ASSERT_TRUE(ctl.set_feed_forward(model));
  EXPECT_EQ(ctl.feed_forward().mode, FeedForwardMode::kModel);
  EXPECT_EQ(ctl.start(before).check.fault, TrajectoryFault::kInvalidConfig);
  ASSERT_TRUE(ctl.start(excitation()).accepted);
  tick(1);
  ASSERT_EQ(ctl.state(), State::kRunning);
  FeedForwardConfig nominal = model;
  nominal.mode = FeedForwardMode::kNominal;
  EXPECT_FALSE(ctl.set_feed_forward(nominal));  // a run is on
  tick(2000);
  EXPECT_EQ(ctl.state(), State::kRunning);
  EXPECT_EQ(ctl.feed_forward().mode, FeedForwardMode::kModel);

  // A heavy platform: the gravity terms alone ask for more than the limit.
  ControllerConfig heavy = config;
  heavy.feed_forward = model;
  delta::fx::ModelParametersQ heavy_parameters = m;
  heavy_parameters.platform_weight_mass_kg = to_q_saturated<Q7_24>(20.0);
  heavy.feed_forward.model = delta::fx::prepare_model(heavy.geometry, heavy_parameters);
  const TrajectoryCheck c = check_trajectory(trajectory_bounds(heavy), excitation());
  EXPECT_EQ(c.fault, TrajectoryFault::kFeedForwardLimit);
  EXPECT_GE(c.joint, 0);
  EXPECT_STREQ(trajectory_fault_name(c.fault), "feed-forward over the max torque");
  // The same limits without the feed-forward's torques: accepted.
  EXPECT_EQ(check_trajectory(heavy.geometry, excitation(), heavy.limits).fault,
            TrajectoryFault::kOk);
}

// The plant's own model (the lumped truth, friction included) as the
// feed-forward: what the collision detector compares the measured torque
// against.
FeedForwardConfig exact_model(const GeometryQ& geometry) {
  const delta::fx::ModelParametersQ m = lumped_truth_q(true);
  FeedForwardConfig f;
  f.mode = FeedForwardMode::kModel;
  f.model = delta::fx::prepare_model(geometry, m);
  return f;
}

CollisionConfig detector(double base_Nm) {
  CollisionConfig c;
  c.detect = true;
  for (unsigned j = 0; j < 3; ++j) {
    c.thresholds.base_Nm[j] = to_q_saturated<Q12_19>(base_Nm);
    c.thresholds.per_speed_Nm_s_per_rad[j] = to_q_saturated<Q12_19>(0.02);
    c.thresholds.per_acceleration_Nm_s2_per_rad[j] = to_q_saturated<Q12_19>(0.001);
  }
  return c;
}

// With the gearboxes' compliance in the model (fw/deflection.hpp), this
// rigid plant's joints sit at reference + c tau_ff, which the controller's
// tracking measures them against; the drives get the arms' reference, and
// the approach starts where the joints are (no step).
TEST_F(ControllerTest, DeflectionCompensationTracksTheMotorsPastTheArmsReference) {
  delta::fx::ModelParametersQ m = lumped_truth_q(true);
  m.gearbox_compliance_rad_per_Nm = {Q1_30::from(1.0 / 3000), Q1_30::from(1.0 / 2000),
                                     Q1_30::from(1.0 / 4000)};
  const FeedForwardConfig f{
      FeedForwardMode::kModel, {}, delta::fx::prepare_model(config.geometry, m)};
  ASSERT_TRUE(compensates_deflection(f));
  to_ready();
  ASSERT_TRUE(ctl.set_feed_forward(f));
  const std::array<double, 3> at_rest = hw.plant.q;
  ASSERT_TRUE(ctl.start(excitation()).accepted);
  tick(2);  // begin the run, then its first controlled tick
  std::array<double, 3> shift_sq{}, off_sq{};
  int n = 0;
  for (unsigned j = 0; j < 3; ++j) {  // the first motor reference: where the joint rested
    EXPECT_EQ(hw.reference[j], ctl.reference().q_rad[j]);
    const double step = FakeHardware::kEncoderStep;  // as the encoder saw it
    Joint3Q12_19 tau{};
    ASSERT_EQ(feed_forward_torque(f, ctl.reference(), tau), delta::KinematicsStatus::kOk);
    const double motor_ref = to_double(ctl.reference().q_rad[j]) +
                             to_double(m.gearbox_compliance_rad_per_Nm[j]) * to_double(tau[j]);
    EXPECT_NEAR(motor_ref, std::round(at_rest[j] / step) * step, 2e-7) << j;
  }
  while (ctl.state() == State::kRunning && n < 20000) {
    const std::array<double, 3> q_seen = hw.plant.q;
    tick();
    Joint3Q12_19 tau{};
    feed_forward_torque(f, ctl.reference(), tau);
    if (ctl.run_tick() < config.approach_ticks) continue;
    for (unsigned j = 0; j < 3; ++j) {
      const double shift = to_double(m.gearbox_compliance_rad_per_Nm[j]) * to_double(tau[j]);
      const double off = q_seen[j] - (to_double(ctl.reference().q_rad[j]) + shift);
      shift_sq[j] += shift * shift;
      off_sq[j] += off * off;
    }
    ++n;
  }
  ASSERT_GT(n, 10000);
  const fw::TrackingStats& t = ctl.tracking();  // the motors' against their reference
  for (unsigned j = 0; j < 3; ++j) {
    const double shift_rms = std::sqrt(shift_sq[j] / n), off_rms = std::sqrt(off_sq[j] / n);
    const double tracking_rms = std::sqrt(std::ldexp(t.sum_sq_rad2_q40[j], -40) / t.ticks);
    std::printf("joint %u: shift rms %.3g rad, off the motor reference %.3g, tracking %.3g\n",
                j + 1, shift_rms, off_rms, tracking_rms);
    EXPECT_GT(shift_rms, 1e-4) << j;
    EXPECT_LT(off_rms, 0.1 * shift_rms) << j;
    EXPECT_LT(tracking_rms, 0.1 * shift_rms) << j;
  }
}

// With the plant's own model as the feed-forward, a clean excitation keeps
// every joint's filtered residual below a threshold of 0.05 N m (plus
// 0.02 N m per rad/s and 0.001 per rad/s^2): no detection. A contact of
// 0.5 N m on joint 2 two seconds into the trajectory is detected within
// 10 ticks: the collision fault, the drives quick-stopped and braked, and
// the event names joint 2 with its residual over its threshold.
TEST_F(ControllerTest, AContactIsDetectedAndQuickStopsTheDrives) {
  to_ready();
  ASSERT_TRUE(ctl.set_feed_forward(exact_model(config.geometry)));
  ASSERT_TRUE(ctl.set_collision(detector(0.05)));
  ASSERT_TRUE(ctl.start(excitation()).accepted);
  tick(1);
  double largest = 0.0;
  while (ctl.state() == State::kRunning) {
    tick();
    for (const Q12_19& r : ctl.collision_residual()) {
      largest = std::max(largest, std::abs(to_double(r)));
    }
  }
  std::printf("clean run: largest filtered residual %.4f N m\n", largest);
  EXPECT_GT(largest, 0.0);  // the detector ran
  EXPECT_EQ(ctl.state(), State::kStopping) << fault_name(ctl.fault());
  EXPECT_FALSE(ctl.collided());
  tick(static_cast<int>(config.stop_ticks) + 1);
  ASSERT_EQ(ctl.state(), State::kReady);

  ASSERT_TRUE(ctl.start(excitation()).accepted);
  tick(1);
  tick(static_cast<int>(config.approach_ticks) + 2000);
  ASSERT_EQ(ctl.state(), State::kRunning);
  hw.external_Nm[1] = 0.5;
  int ticks = 0;
  while (ctl.state() == State::kRunning && ticks < 100) {
    tick();
    ++ticks;
  }
  std::printf("contact of 0.5 N m on joint 2 detected after %d ticks\n", ticks);
  EXPECT_LE(ticks, 10);
  expect_fault(Fault::kCollision);
  EXPECT_TRUE(hw.quick_stopped);
  ASSERT_TRUE(ctl.collided());
  EXPECT_EQ(ctl.collision().joint, 1);
  EXPECT_GT(delta::fx::abs(ctl.collision().residual_Nm[1]), ctl.collision().threshold_Nm[1]);
  EXPECT_EQ(ctl.collision_run_tick(), ctl.run_tick());
  // Recovery is an explicit reset.
  hw.external_Nm = {};
  tick(10);
  expect_fault(Fault::kCollision);
  ctl.reset();
  tick(6);
  EXPECT_EQ(ctl.state(), State::kReady);
}

TEST_F(ControllerTest, EStopDisablesTheDrivesWithinTheSameCycle) {
  to_running();
  tick(300);
  hw.estop = true;
  const int cycle = hw.cycle;
  ctl.step();
  EXPECT_EQ(hw.drives_disabled_at_cycle, cycle);
  expect_fault(Fault::kEStop);
  EXPECT_EQ(static_cast<int>(Fault::kEStop), 1);  // stable code
}

TEST_F(ControllerTest, DriveFaultHeartbeatAndLimitsEachLeadToTheirFault) {
  struct Case {
    const char* name;
    void (*inject)(FakeHardware&);
    Fault expected;
    int max_cycles;
  };
  const Case cases[] = {
      {"drive fault", [](FakeHardware& h) { h.drive_fault = true; }, Fault::kDriveFault, 1},
      {"stale feedback", [](FakeHardware& h) { h.stale_feedback = true; }, Fault::kHeartbeatLost,
       3},
      {"malformed frame",
       [](FakeHardware& h) { h.problem_on_joint2 = FeedbackProblem::kMalformed; },
       Fault::kFeedbackMalformed, 1},
      {"bus error", [](FakeHardware& h) { h.problem_on_joint2 = FeedbackProblem::kBusError; },
       Fault::kCanBusError, 1},
      {"late feedback", [](FakeHardware& h) { h.problem_on_joint2 = FeedbackProblem::kLate; },
       Fault::kFeedbackLate, 3},
      {"joint limit", [](FakeHardware& h) { h.position_offset_rad = 2.0; }, Fault::kJointLimit, 1},
      {"velocity limit", [](FakeHardware& h) { h.velocity_offset_rad_s = 50.0; },
       Fault::kVelocityLimit, 1},
      {"tracking error", [](FakeHardware& h) { h.position_offset_rad = 0.3; },
       Fault::kTrackingError, 1},
      {"log overflow", [](FakeHardware& h) { h.log_capacity = h.log_records.size(); },
       Fault::kLogOverflow, 1},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    FakeHardware h;
    ControllerConfig cfg = default_config();
    h.config = &cfg;
    Controller<FakeHardware> ctrl(h, cfg);
    for (int i = 0; i < 5; ++i) ctrl.step();
    ASSERT_TRUE(ctrl.start(excitation()).accepted);
    for (int i = 0; i < 200; ++i) {
      ctrl.step();
      h.physics(1e-3);
    }
    ASSERT_EQ(ctrl.state(), State::kRunning);
    c.inject(h);
    int n = 0;
    while (ctrl.state() != State::kFault && n < 10) {
      ctrl.step();
      ++n;
    }
    EXPECT_EQ(ctrl.fault(), c.expected) << fault_name(ctrl.fault());
    EXPECT_EQ(n, c.max_cycles);
    EXPECT_FALSE(h.drives_enabled);
    EXPECT_FALSE(h.outputs.brake_release);
  }
}

TEST_F(ControllerTest, ACycleWithMissingFeedbackIsLoggedAsStaleAndTheRunGoesOn) {
  to_running();
  tick(300);
  // Joint 2's answer misses two cycles (fewer than lost_feedback_ticks).
  hw.problem_on_joint2 = FeedbackProblem::kLate;
  tick(2);
  hw.problem_on_joint2 = FeedbackProblem::kNone;
  tick(300);
  ASSERT_EQ(ctl.state(), State::kRunning);
  std::vector<std::uint32_t> stale;
  for (std::size_t i = 0; i < hw.log_records.size(); ++i) {
    EXPECT_EQ(hw.log_records[i].seq, i);  // the seq goes on through them
    if (hw.log_records[i].stale) stale.push_back(hw.log_records[i].seq);
  }
  ASSERT_EQ(stale.size(), 2u);
  EXPECT_EQ(stale[1], stale[0] + 1);
  EXPECT_EQ(stale[0], 300u);  // records 0..299 came before
  EXPECT_EQ(ctl.stale_log_records(), 2u);
}

TEST_F(ControllerTest, AJammedJointTripsTheTrackingLimit) {
  to_running();
  hw.plant.stuck = true;
  int n = 0;
  while (ctl.state() == State::kRunning && n < 20000) {
    tick();
    ++n;
  }
  expect_fault(Fault::kTrackingError);
}

TEST_F(ControllerTest, DriveConfigurationFailureAndTimeout) {
  hw.configure_fails = true;
  tick(2);
  expect_fault(Fault::kDriveConfigFailed);

  FakeHardware h;
  ControllerConfig cfg = default_config();
  cfg.configure_timeout_ticks = 50;
  h.config = &cfg;
  h.configure_calls_until_done = 1000000;
  Controller<FakeHardware> slow(h, cfg);
  for (int i = 0; i < 60; ++i) slow.step();
  EXPECT_EQ(slow.fault(), Fault::kDriveConfigFailed);
}

TEST_F(ControllerTest, ResetNeedsTheEStopClosedAndStartsAgainAtBoot) {
  to_running();
  hw.estop = true;
  tick(1);
  expect_fault(Fault::kEStop);
  ctl.reset();
  tick(1);
  EXPECT_EQ(ctl.state(), State::kFault);  // e-stop still open
  hw.estop = false;
  tick(3);
  EXPECT_EQ(ctl.state(), State::kFault);  // no reset asked since
  ctl.reset();
  hw.configure_calls_until_done = 2;
  tick(1);
  EXPECT_EQ(ctl.state(), State::kBoot);
  EXPECT_EQ(ctl.fault(), Fault::kNone);
  tick(4);
  EXPECT_EQ(ctl.state(), State::kReady);
}

}  // namespace
}  // namespace fw
