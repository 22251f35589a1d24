// The logged torque's lag behind the motion (torque_lag.hpp, docs/trust.md)
// on multibody robots whose drives report their current through a
// first-order filter: none without a filter, the default robot's 0.5 ms
// costs nothing at a Fourier log's bandwidth, and a 3 ms one is named as a
// doubt.
#include <gtest/gtest.h>

#include <iostream>

#include "fit_fixtures.hpp"

namespace host_id {
namespace {

FitResult fit_with_current_filter(double time_constant_s) {
  delta::RobotDescription r = test::heavy_robot();
  for (auto& joint : r.joints) joint.current_filter_time_constant_s = time_constant_s;
  return fit_log(test::multibody_log(r), test::least_squares());
}

bool doubt_names_the_lag(const FitResult& fit) {
  for (const std::string& d : fit.doubts) {
    if (d.find("the logged torque lags the motion") != std::string::npos) return true;
  }
  return false;
}

// The lag the fitted model leaves is the filter's less what the fit's
// inertias and viscous friction absorb (measured: 0 ms of 0.5, 2.3 ms of
// 3): a lower bound of the drive's delay, and the part that matters.
TEST(TorqueLagTest, ALongCurrentFilterIsNamedAndTheDefaultOneCostsNothing) {
  struct Case {
    double filter_s, lag_min_s, lag_max_s;
    bool doubt;
  };
  for (const Case c : {Case{0.0, -0.3e-3, 0.3e-3, false}, Case{0.5e-3, -0.3e-3, 0.8e-3, false},
                       Case{3e-3, 1.5e-3, 3.3e-3, true}}) {
    const FitResult fit = fit_with_current_filter(c.filter_s);
    ASSERT_TRUE(fit.torque_lag.has_value());
    std::cout << "  current filter " << c.filter_s * 1e3 << " ms: lag "
              << fit.torque_lag->lag_s * 1e3 << " ms, error drop "
              << 100.0 * fit.torque_lag->error_drop << " %\n";
    EXPECT_GE(fit.torque_lag->lag_s, c.lag_min_s) << c.filter_s;
    EXPECT_LE(fit.torque_lag->lag_s, c.lag_max_s) << c.filter_s;
    EXPECT_EQ(fit.torque_lag->error_drop >= kTorqueLagDoubt, c.doubt) << c.filter_s;
    EXPECT_EQ(doubt_names_the_lag(fit), c.doubt) << c.filter_s;
  }
}

}  // namespace
}  // namespace host_id
