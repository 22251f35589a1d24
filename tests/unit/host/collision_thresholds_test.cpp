// The collision detector's thresholds a fit derives (docs/safety.md,
// collision_thresholds.hpp) hold both ways on multibody robots with
// effects the model lacks: the controller's residual (measured minus model
// torque, filtered as the controller filters it) never reaches them on the
// fitted log, nor on a held-out log of the same kind of motion; and they
// are never looser than that held-out residual supports: its peak is at
// least a quarter of the threshold.
#include "host_id/collision_thresholds.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>

#include "fit_fixtures.hpp"
#include "host_id/predict.hpp"

namespace host_id {
namespace {

// The largest ratio, over a log's samples and joints, of the controller's
// filtered residual to its threshold at the sample's speed and
// acceleration.
double worst_ratio(const FitResult& fit, const DeltaLog& log) {
  const auto model = make_model(fit.options.model);
  const PredictedLog p = predict_log(*model, fit.beta, log, fit.options.prepare, "fit");
  const delta::CollisionThresholds& t = fit.collision->thresholds;
  double worst = 0.0;
  for (unsigned j = 0; j < 3; ++j) {
    const Series& tau = p.log.tau[j];
    const Series& tau_model = p.log.extra_columns[j].second;
    double filtered = 0.0;
    for (std::size_t k = 0; k < tau.size(); ++k) {
      const double r = tau[k] - tau_model[k];
      filtered = k == 0 ? r : filtered + (r - filtered) / kCollisionFilterTicks;
      const double threshold = t.base_Nm[j] +
                               t.per_speed_Nm_s_per_rad[j] * std::abs(p.log.qd[j][k]) +
                               t.per_acceleration_Nm_s2_per_rad[j] * std::abs(p.log.qdd[j][k]);
      worst = std::max(worst, std::abs(filtered) / threshold);
    }
  }
  return worst;
}

void expect_thresholds_hold_both_ways(bool drive_train, const ModelOptions& m = {}) {
  const delta::RobotDescription robot = test::flawed_robot(drive_train);
  const DeltaLog fitted = test::multibody_log(robot, 0.2, "fourier", 1);
  const DeltaLog held_out = test::multibody_log(robot, 0.2, "fourier", 2);
  const FitResult fit = fit_log(fitted, test::least_squares(m));
  ASSERT_TRUE(fit.collision.has_value()) << fit.collision_unavailable;
  const double on_fitted = worst_ratio(fit, fitted);
  const double on_held_out = worst_ratio(fit, held_out);
  const delta::CollisionThresholds& t = fit.collision->thresholds;
  std::cout << "  base " << t.base_Nm[0] << ", " << t.base_Nm[1] << ", " << t.base_Nm[2]
            << " N m; residual / threshold at worst: fitted log " << on_fitted << ", held out "
            << on_held_out << "\n";
  EXPECT_LT(on_fitted, 1.0);
  EXPECT_LT(on_held_out, 1.0);
  EXPECT_GE(on_held_out, 0.25);
}

TEST(CollisionThresholdsTest, HoldOnARigidRobotWithFlawsTheModelLacks) {
  expect_thresholds_hold_both_ways(false);
}

TEST(CollisionThresholdsTest, HoldOnTheDriveTrainRobot) {
  expect_thresholds_hold_both_ways(true);
}

// A model with the drive train's torque gains and load friction (what
// --model auto takes on such a robot), which the controller runs too.
TEST(CollisionThresholdsTest, HoldForADriveTrainModel) {
  ModelOptions m;
  m.torque_gains = true;
  m.load_friction = true;
  expect_thresholds_hold_both_ways(true, m);
}

// paper14's coefficients do not run on the controller: none, and why.
TEST(CollisionThresholdsTest, NoneForAModelTheControllerDoesNotRun) {
  const FitResult fit = fit_log(test::multibody_log(test::flawed_robot(false)),
                                test::least_squares(test::model_named("paper14")));
  EXPECT_FALSE(fit.collision.has_value());
  EXPECT_NE(fit.collision_unavailable.find("does not run on the controller"), std::string::npos)
      << fit.collision_unavailable;
}

}  // namespace
}  // namespace host_id
