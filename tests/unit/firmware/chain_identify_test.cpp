// The whole chain in one process: the firmware's port drives the emulator
// along path1, the recorder's assembler decodes the log frames, and the fit
// identifies the emulator's truth. Without the VM, so the numbers are
// repeatable and the test runs under the sanitizers too.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "chain_runs.hpp"
#include "delta/model_q.hpp"
#include "fw_linux/trajectories.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"
#include "host_id/recorder.hpp"
#include "host_id/report.hpp"
#include "in_process_rig.hpp"

namespace fw_linux {
namespace {

host_id::FitOptions least_squares_per_joint() {
  host_id::FitOptions o;
  o.method = host_id::Method::kLeastSquares;
  o.model.name = "lumped";  // the plant's own model
  o.model.per_joint = true;
  return o;
}

double parameter(const host_id::FitResult& r, const std::string& name) {
  for (const auto& p : r.parameters)
    if (p.info.name == name) return p.value;
  ADD_FAILURE() << "no parameter " << name;
  return 0.0;
}

double relative_error(double value, double truth) {
  return value / truth - 1.0;
}

// Noise-free currents isolate the bias of the method from the noise's
// spread. Measured: with every sample the viscous friction comes out +4.2,
// +4.0 and +6.8 % high; leaving out the equations slower than the default
// minimum speed, -1.2, +1.8 and -0.3 %.
TEST(ChainIdentify, ViscousFrictionUnbiasedWithoutTheSlowEquations) {
  emu::EmulatorConfig ec;
  ec.current_noise_A = 0.0;
  const host_id::DeltaLog log = record_path1(ec).log;
  ASSERT_GT(log.size(), 7000u);
  const auto& truth = ec.truth;

  const host_id::FitResult fit = host_id::fit_log(log, least_squares_per_joint());
  EXPECT_EQ(fit.min_speed_rad_s, host_id::kDefaultMinSpeedRadS);
  double without = 0.0;  // the worst viscous error without the slow equations
  for (unsigned j = 0; j < 3; ++j) {
    const std::string n = std::to_string(j + 1);
    SCOPED_TRACE("joint " + n);
    EXPECT_LT(fit.equations_used[j], fit.fit.samples);
    EXPECT_GT(fit.equations_used[j], fit.fit.samples * 3 / 4);
    without = std::max(without, std::abs(relative_error(parameter(fit, "viscous_friction_" + n),
                                                        truth.viscous_friction_Nm_s_per_rad[j])));
    EXPECT_NEAR(relative_error(parameter(fit, "viscous_friction_" + n),
                               truth.viscous_friction_Nm_s_per_rad[j]),
                0.0, 0.03);
    EXPECT_NEAR(
        relative_error(parameter(fit, "coulomb_friction_" + n), truth.coulomb_friction_Nm[j]), 0.0,
        0.01);
    EXPECT_NEAR(relative_error(parameter(fit, "arm_inertia_" + n), truth.arm_inertia_kg_m2[j]), 0.0,
                0.01);
  }
  EXPECT_NEAR(relative_error(parameter(fit, "platform_mass"), truth.platform_mass_kg), 0.0, 0.005);

  // Every equation: the bias this option is for.
  host_id::FitOptions all = least_squares_per_joint();
  all.min_speed_rad_s = 0.0;
  const host_id::FitResult biased = host_id::fit_log(log, all);
  double worst = 0.0;
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_EQ(biased.equations_used[j], biased.fit.samples);
    worst = std::max(worst,
                     relative_error(parameter(biased, "viscous_friction_" + std::to_string(j + 1)),
                                    truth.viscous_friction_Nm_s_per_rad[j]));
  }
  // Measured: 3.4 % with every equation, 2.0 % without the slow ones (with
  // q filtered at 20 Hz whatever the log, the first was 5-7 %: the sharper
  // states of a cut-off chosen from the log's content leave less bias).
  std::printf(
      "viscous friction's worst error: %.4f with every equation, %.4f without the slow "
      "ones\n",
      worst, without);
  EXPECT_GT(worst, without + 0.01);
}

// With the emulator's current noise the viscous estimate scatters by about
// 2 % from run to run (measured over 14 seeds: 1.9, 0.9 and 2.3 %), and the
// standard deviation the fit prints says so (it said 0.6, 0.3 and 0.6 % when
// it assumed white residuals). Here: each parameter lies within two of its
// printed standard deviations (docs/trust.md: the larger of least squares'
// and the spread over the log's motions), which least squares' own breaks
// (viscous_friction_2: 2.8 of them), and none is so wide as to be useless
// (below 20 % of its value; measured 0.5-15 %).
TEST(ChainIdentify, PrintedStandardDeviationCoversTheErrors) {
  emu::EmulatorConfig ec;
  ec.seed = 14;  // with white-noise deviations four parameters fail, one by 7 of them
  const host_id::DeltaLog log = record_path1(ec).log;
  const host_id::FitResult fit = host_id::fit_log(log, least_squares_per_joint());
  const auto& truth = ec.truth;
  for (unsigned j = 0; j < 3; ++j) {
    const std::string n = std::to_string(j + 1);
    for (const auto& p : fit.parameters) {
      double t = 0.0;
      if (p.info.name == "viscous_friction_" + n)
        t = truth.viscous_friction_Nm_s_per_rad[j];
      else if (p.info.name == "coulomb_friction_" + n)
        t = truth.coulomb_friction_Nm[j];
      else if (p.info.name == "arm_inertia_" + n)
        t = truth.arm_inertia_kg_m2[j];
      else
        continue;
      SCOPED_TRACE(p.info.name);
      EXPECT_LT(std::abs(p.value - t), 2.0 * p.std_dev);
      EXPECT_LT(p.rel_std_percent, 20.0);
    }
  }
}

}  // namespace
}  // namespace fw_linux

namespace fw_linux {
namespace {

// A cycle whose feedback came after the deadline has a record with the last
// position and current of the late drive. The controller marks it stale,
// the recorder leaves it out, and the fit splits there. (Measured: four
// such records taken as samples moved the viscous estimates by at most
// 1 point here, so they do not explain the -9.2 % of a starved VM run.)
TEST(ChainIdentify, LateFeedbackCyclesAreLeftOutOfTheLog) {
  emu::EmulatorConfig ec;
  ec.current_noise_A = 0.0;
  const std::vector<int> late{1500, 3000, 4500, 6000};
  const Path1Run marked = record_path1(ec, late);
  EXPECT_EQ(marked.stale, late.size());
  EXPECT_EQ(marked.log.gaps.size(), late.size());  // kept in seq
  const Path1Run taken = record_path1(ec, late, true);
  EXPECT_EQ(taken.stale, 0u);
  EXPECT_EQ(taken.log.size(), marked.log.size() + late.size());
  const host_id::FitResult fit = host_id::fit_log(marked.log, least_squares_per_joint());
  EXPECT_EQ(fit.segments_used, late.size() + 1);
  for (unsigned j = 0; j < 3; ++j) {
    const std::string n = std::to_string(j + 1);
    SCOPED_TRACE("joint " + n);
    EXPECT_NEAR(relative_error(parameter(fit, "viscous_friction_" + n),
                               ec.truth.viscous_friction_Nm_s_per_rad[j]),
                0.0, 0.03);
    EXPECT_NEAR(relative_error(parameter(fit, "arm_inertia_" + n), ec.truth.arm_inertia_kg_m2[j]),
                0.0, 0.01);
  }
}

}  // namespace
}  // namespace fw_linux

namespace fw_linux {
namespace {

struct Tracking {
  std::array<double, 3> rms_rad{}, max_rad{};
  double worst_rms() const { return *std::max_element(rms_rad.begin(), rms_rad.end()); }
};

Tracking tracking_of(const fw::TrackingStats& t) {
  Tracking r;
  for (unsigned j = 0; j < 3; ++j) {
    const double ticks = t.ticks > 0 ? static_cast<double>(t.ticks) : 1.0;
    r.rms_rad[j] = std::sqrt(static_cast<double>(t.sum_sq_rad2_q40[j]) / ticks) / 1048576.0;
    r.max_rad[j] = t.max_abs_rad[j].raw() / 268435456.0;
  }
  return r;
}

// The point of identifying: the controller runs the model `host_id fit`
// identified from its own path1 log (saved and read back as a user's
// RESULT.json) as its feed-forward, on the multibody robot, and the
// pick-and-place tracks at least 5 times better (worst joint's RMS) than
// with the nominal feed-forward. Same rig, gains and trajectory.
TEST(ChainIdentify, TheIdentifiedModelAsFeedForwardTracksFiveTimesBetter) {
  emu::EmulatorConfig ec;
  ec.plant = emu::PlantKind::kMujoco;
  Rig rig(ec);
  const host_id::DeltaLog log = record_path1(rig, ec).log;
  ASSERT_GT(log.size(), 7000u);
  host_id::FitOptions options;
  options.method = host_id::Method::kLeastSquares;  // the optimum PSO must also reach
  const host_id::FitResult fit = host_id::fit_log(log, options);
  const std::string path = ::testing::TempDir() + "feed_forward_model.json";
  {
    std::ofstream out(path);
    out << host_id::json_report(fit).dump(2);
  }
  const delta::IdentifiedModel model = delta::read_identified_model(path);
  EXPECT_TRUE(delta::model_problems(model, ec.geometry).empty());

  run_trajectory(rig, "pick-and-place", nullptr);
  const Tracking nominal = tracking_of(rig.controller.tracking());

  fw::FeedForwardConfig ff = rig.controller.feed_forward();
  ff.mode = fw::FeedForwardMode::kModel;
  ff.model = delta::fx::prepare_model(controller_config(Rig::config()).geometry,
                                      delta::model_parameters_q(model));
  ASSERT_TRUE(rig.controller.set_feed_forward(ff));
  run_trajectory(rig, "pick-and-place", nullptr);
  const Tracking identified = tracking_of(rig.controller.tracking());

  std::printf("pick-and-place tracking, nominal: rms %.5f %.5f %.5f max %.5f %.5f %.5f rad\n",
              nominal.rms_rad[0], nominal.rms_rad[1], nominal.rms_rad[2], nominal.max_rad[0],
              nominal.max_rad[1], nominal.max_rad[2]);
  std::printf("pick-and-place tracking, model:   rms %.5f %.5f %.5f max %.5f %.5f %.5f rad\n",
              identified.rms_rad[0], identified.rms_rad[1], identified.rms_rad[2],
              identified.max_rad[0], identified.max_rad[1], identified.max_rad[2]);
  std::printf("worst joint's RMS %.2fx lower\n", nominal.worst_rms() / identified.worst_rms());
  EXPECT_GE(nominal.worst_rms(), 5.0 * identified.worst_rms());
}

}  // namespace
}  // namespace fw_linux
