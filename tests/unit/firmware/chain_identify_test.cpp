// The whole chain in one process: the firmware's port drives the emulator
// along path1, the recorder's assembler decodes the log frames, and the fit
// identifies the emulator's truth. Without the VM, so the numbers are
// repeatable and the test runs under the sanitizers too.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "fw_linux/trajectories.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"
#include "host_id/recorder.hpp"
#include "in_process_rig.hpp"

namespace fw_linux {
namespace {

struct Path1Run {
  host_id::DeltaLog log;
  std::uint64_t stale{0};
};

// The log of one path1 run, as host_id record would write it (sequence
// numbers from 0, time from the sequence and the configured rate). Node 3's
// TPDO1 misses the deadline in the cycles `late_cycles` of the run; with
// `ignore_stale_mark` the records of those cycles are taken as samples.
Path1Run record_path1(const emu::EmulatorConfig& ec, const std::vector<int>& late_cycles = {},
                      bool ignore_stale_mark = false) {
  Rig rig(ec);
  for (int i = 0; i < 2000 && rig.controller.state() != fw::State::kReady; ++i) rig.cycle();
  EXPECT_EQ(rig.controller.state(), fw::State::kReady);
  const auto trajectory = named_trajectory("path1", Rig::config());
  EXPECT_TRUE(trajectory.has_value());
  EXPECT_TRUE(rig.controller.start(*trajectory).accepted);
  host_id::LogAssembler assembler;
  for (int i = 0; i < 20000; ++i) {
    rig.bus.sent_.clear();
    const bool late = std::find(late_cycles.begin(), late_cycles.end(), i) != late_cycles.end();
    rig.bus.make_late(late ? delta::can::protocol::cob_id(delta::can::protocol::kTpdo1, 3) : ~0u);
    rig.cycle();
    for (auto f : rig.bus.sent_) {
      if (ignore_stale_mark)
        delta::can::protocol::pack(f.data, delta::can::protocol::kLogAStale, 0);
      assembler.feed(f);
    }
    if (i > 0 && rig.controller.state() == fw::State::kReady) break;
  }
  assembler.finish();
  EXPECT_EQ(assembler.lost_samples(), 0u);
  const auto samples = assembler.take_complete();
  const double rate_hz = 1e6 / Rig::config().period_us;
  Path1Run run;
  run.stale = assembler.stale_samples();
  host_id::DeltaLog& log = run.log;
  log.name = "path1 (in-process)";
  log.geometry = ec.geometry;
  log.sample_rate_hz = rate_hz;
  for (const auto& s : samples) {
    const std::uint64_t seq = s.seq - samples.front().seq;
    log.seq.push_back(seq);
    log.t.push_back(static_cast<double>(seq) / rate_hz);
    for (unsigned j = 0; j < 3; ++j) {
      log.q[j].push_back(s.q_rad[j]);
      log.tau[j].push_back(s.tau_Nm[j]);
    }
  }
  // Written and read back as host_id record and fit do: the reader finds the
  // gaps in seq, where the fit splits.
  run.log = host_id::parse_delta_log(host_id::format_delta_log(log), log.name);
  return run;
}

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
  for (unsigned j = 0; j < 3; ++j) {
    const std::string n = std::to_string(j + 1);
    SCOPED_TRACE("joint " + n);
    EXPECT_LT(fit.equations_used[j], fit.fit.samples);
    EXPECT_GT(fit.equations_used[j], fit.fit.samples * 3 / 4);
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
  EXPECT_GT(worst, 0.05);
}

// With the emulator's current noise the viscous estimate scatters by about
// 2 % from run to run (measured over 14 seeds: 1.9, 0.9 and 2.3 %), and the
// standard deviation the fit prints says so: it allows for the filtered
// residuals' correlation (it said 0.6, 0.3 and 0.6 % when it assumed them
// white). Here: each parameter lies within four of its printed standard
// deviations, which a white-noise deviation would break.
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
      EXPECT_LT(std::abs(p.value - t), 4.0 * p.std_dev);
      EXPECT_LT(p.rel_std_percent, 5.0);
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
