// host_id simulate's library: what it reports while it runs.
#include "host_id/simulate.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace host_id {
namespace {

// A long simulation says how far it is, every 1 % of its samples and at
// its end, for both plants; the log is the same with or without it.
TEST(SimulateTest, ProgressIsReportedEveryPercentUpToTheEnd) {
  for (const SimulatedPlant plant : {SimulatedPlant::kLumped, SimulatedPlant::kMujoco}) {
    SimulateOptions o;
    o.plant = plant;
    o.duration_s = 2.0;
    std::vector<std::size_t> done;
    std::size_t total = 0;
    o.progress = [&](std::size_t d, std::size_t t) {
      done.push_back(d);
      total = t;
    };
    const DeltaLog log = simulate_log(o);
    EXPECT_EQ(total, log.size());
    ASSERT_GE(done.size(), 100u);
    EXPECT_LE(done.size(), 101u);
    EXPECT_EQ(done.back(), log.size());
    for (std::size_t i = 1; i < done.size(); ++i) EXPECT_GT(done[i], done[i - 1]);
    o.progress = nullptr;
    EXPECT_EQ(simulate_log(o).tau[0], log.tau[0]);
  }
}

}  // namespace
}  // namespace host_id
