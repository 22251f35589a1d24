// The in-process chain's runs, for the tests that drive the emulator
// through the firmware's port (chain_identify_test, chain_collision_test):
// a named trajectory from ready to its end, and path1 recorded as host_id
// record would write it.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "fw_linux/trajectories.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/recorder.hpp"
#include "in_process_rig.hpp"

namespace fw_linux {

struct Path1Run {
  host_id::DeltaLog log;
  std::uint64_t stale{0};
};

// Runs a named trajectory from ready to its end on the rig, the log frames
// to `assembler` where given (after `edit`, which may change them); node 3's
// TPDO1 misses the deadline in the cycles `late_cycles`.
inline void run_trajectory(Rig& rig, const std::string& name, host_id::LogAssembler* assembler,
                           const std::vector<int>& late_cycles = {},
                           void (*edit)(delta::can::Frame&) = nullptr) {
  for (int i = 0; i < 2000 && rig.controller.state() != fw::State::kReady; ++i) rig.cycle();
  ASSERT_EQ(rig.controller.state(), fw::State::kReady);
  const auto trajectory = named_trajectory(name, Rig::config());
  ASSERT_TRUE(trajectory.has_value());
  const fw::StartResult start = rig.controller.start(*trajectory);
  ASSERT_TRUE(start.accepted) << fw::trajectory_fault_name(start.check.fault) << " at tick "
                              << start.check.tick << ", joint " << start.check.joint;
  for (int i = 0; i < 40000; ++i) {
    rig.bus.sent_.clear();
    const bool late = std::find(late_cycles.begin(), late_cycles.end(), i) != late_cycles.end();
    rig.bus.make_late(late ? delta::can::protocol::cob_id(delta::can::protocol::kTpdo1, 3) : ~0u);
    rig.cycle();
    for (auto f : rig.bus.sent_) {
      if (edit != nullptr) edit(f);
      if (assembler != nullptr) assembler->feed(f);
    }
    if (i > 0 && rig.controller.state() != fw::State::kRunning &&
        rig.controller.state() != fw::State::kStopping) {
      break;
    }
  }
  EXPECT_EQ(rig.controller.state(), fw::State::kReady) << fw::fault_name(rig.controller.fault());
}

// The log of one path1 run, as host_id record would write it (sequence
// numbers from 0, time from the sequence and the configured rate). Node 3's
// TPDO1 misses the deadline in the cycles `late_cycles` of the run; with
// `ignore_stale_mark` the records of those cycles are taken as samples.
inline Path1Run record_path1(Rig& rig, const emu::EmulatorConfig& ec,
                             const std::vector<int>& late_cycles = {},
                             bool ignore_stale_mark = false) {
  host_id::LogAssembler assembler;
  run_trajectory(
      rig, "path1", &assembler, late_cycles,
      ignore_stale_mark
          ? +[](delta::can::Frame&
                    f) { delta::can::protocol::pack(f.data, delta::can::protocol::kLogAStale, 0); }
          : nullptr);
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

inline Path1Run record_path1(const emu::EmulatorConfig& ec,
                             const std::vector<int>& late_cycles = {},
                             bool ignore_stale_mark = false) {
  Rig rig(ec);
  return record_path1(rig, ec, late_cycles, ignore_stale_mark);
}

}  // namespace fw_linux
