// host_id excite's decisions that need no controller: why a run ended from
// one poll of the input registers, the exit status a run and its recording
// come to, and the recorder's options from the controller's registers.
// The whole session runs on vcan (HostExcite in tests/hil).
#include "host_id/excite.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "delta/modbus/register_map.hpp"

namespace host_id {
namespace {

namespace mb = delta::modbus;

std::vector<std::uint16_t> inputs(std::int64_t run_id, mb::RunResult result) {
  std::vector<std::uint16_t> in(mb::kInputCount, 0);
  mb::encode(mb::named("run_id"), run_id, in.data());
  mb::encode(mb::named("run_result"), static_cast<std::int64_t>(result), in.data());
  return in;
}

TEST(ExciteTest, ARunGoesOnUntilItsResultSaysOtherwise) {
  EXPECT_FALSE(poll_ending(inputs(5, mb::RunResult::kRunning), 5));
  const auto finished = poll_ending(inputs(5, mb::RunResult::kFinished), 5);
  ASSERT_TRUE(finished);
  EXPECT_EQ(*finished, "");
  EXPECT_EQ(poll_ending(inputs(5, mb::RunResult::kStopped), 5),
            "the run was stopped by another client");
  EXPECT_EQ(poll_ending(inputs(6, mb::RunResult::kRunning), 5), "another client started run #6");
}

TEST(ExciteTest, AFaultEndsTheRunNamingTheFaultAndItsCycle) {
  std::vector<std::uint16_t> in = inputs(2, mb::RunResult::kFaulted);
  mb::encode(mb::named("fault_code"), 2, in.data());
  mb::encode(mb::named("fault_history_0_cycle"), 6012, in.data());
  const auto ending = poll_ending(in, 2);
  ASSERT_TRUE(ending);
  EXPECT_EQ(ending->rfind("the controller faulted: fault 2 (", 0), 0u) << *ending;
  EXPECT_NE(ending->find(") at cycle 6012"), std::string::npos) << *ending;
}

TEST(ExciteTest, TheExitStatusSaysWhatTheLogLacks) {
  RecordSummary all;
  all.samples = 7199;
  all.stale = 2;
  EXPECT_EQ(excite_verdict("", all, 7201, "run.csv").exit_code, 0);
  EXPECT_EQ(excite_verdict("", all, UINT64_MAX, "run.csv").exit_code, 0);
  const ExciteVerdict short_log = excite_verdict("", all, 7205, "run.csv");
  EXPECT_EQ(short_log.exit_code, kExitExciteSamplesLost);
  EXPECT_EQ(short_log.message, "the log ends 4 record(s) short of the 7205 the controller sent");
  RecordSummary lost = all;
  lost.lost = 3;
  EXPECT_EQ(excite_verdict("", lost, 7201, "run.csv").exit_code, kExitExciteSamplesLost);
  const ExciteVerdict unfinished =
      excite_verdict("interrupted (Ctrl-C); the run was stopped", lost, 7201, "run.partial.csv");
  EXPECT_EQ(unfinished.exit_code, kExitExciteNotFinished);
  EXPECT_EQ(unfinished.message,
            "interrupted (Ctrl-C); the run was stopped; the partial log is run.partial.csv");
}

TEST(ExciteTest, TheRecorderTakesTheControllersRateAndGeometry) {
  std::vector<std::uint16_t> in(mb::kInputCount, 0);
  mb::encode(mb::named("period_us"), 2000, in.data());
  mb::encode(mb::named("upper_arm_length"), 200000, in.data());  // um
  ExciteOptions o;
  o.iface = "vcan0";
  o.out_path = "run.csv";
  o.rated_current_A = 3.5;
  const RecordOptions r = record_options(o, in);
  EXPECT_EQ(r.sample_rate_hz, 500.0);
  EXPECT_DOUBLE_EQ(r.geometry.upper_arm_length_m, 0.2);
  EXPECT_EQ(r.rated_current_A, 3.5);
  EXPECT_EQ(r.iface, "vcan0");
  EXPECT_FALSE(r.raw_path);
}

}  // namespace
}  // namespace host_id
