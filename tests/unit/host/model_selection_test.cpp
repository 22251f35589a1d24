// Choosing the model variant the data support (--model auto): held-out
// error over time blocks, on logs whose truth says which variant is right.
#include "host_id/model_selection.hpp"

#include <gtest/gtest.h>

#include <iostream>

#include "fit_fixtures.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/simulate.hpp"

namespace host_id {
namespace {

DeltaLog lumped_log(const delta::LumpedParameters& truth, std::uint64_t seed,
                    const std::string& trajectory = "fourier") {
  SimulateOptions o;
  o.trajectory = trajectory;
  o.seed = seed;
  o.torque_noise = 0.015;
  o.encoder_bits = 17;
  o.duration_s = 16.0;
  o.base_frequency_hz = 0.25;
  o.parameters = truth;
  DeltaLog log = simulate_log(o);
  log.name = "sim-" + std::to_string(seed);
  return log;
}

void print(const ModelSelection& s) {
  for (const VariantScore& v : s.variants) {
    std::cout << "  " << v.name << " (" << v.parameters << "): " << v.held_out_rmse_Nm << " N m\n";
  }
  std::cout << "  chosen: " << s.reason << "\n";
}

TEST(ModelSelectionTest, EqualArmsKeepTheSharedModel) {
  const ModelSelection s =
      select_model(lumped_log(delta::default_lumped_parameters(), 31), test::least_squares());
  print(s);
  ASSERT_EQ(s.variants.size(), 7u);  // 4 arms and offsets; gains, load friction, both
  EXPECT_FALSE(s.variants[s.chosen].model.per_joint);
  EXPECT_FALSE(s.variants[s.chosen].model.offsets);
}

TEST(ModelSelectionTest, ArmsThatDifferByFivePerCentChoosePerJointArms) {
  delta::LumpedParameters p = delta::default_lumped_parameters();
  p.arm_inertia_kg_m2 = {p.arm_inertia_kg_m2[0] * 1.05, p.arm_inertia_kg_m2[1],
                         p.arm_inertia_kg_m2[2] * 0.95};
  p.arm_gravity_moment_Nm = {p.arm_gravity_moment_Nm[0] * 0.95, p.arm_gravity_moment_Nm[1],
                             p.arm_gravity_moment_Nm[2] * 1.05};
  const ModelSelection s = select_model(lumped_log(p, 32), test::least_squares());
  print(s);
  EXPECT_TRUE(s.variants[s.chosen].model.per_joint);
  EXPECT_FALSE(s.variants[s.chosen].model.offsets);
}

// Torque offsets: over the Fourier path's small joint swings per-joint
// gravity moments explain them as well, and the selection says so; over
// pick-and-place's wider ones the offsets are chosen.
TEST(ModelSelectionTest, TorqueOffsetsAreChosenWhereTheLogCanTellThem) {
  delta::LumpedParameters p = delta::default_lumped_parameters();
  p.torque_offset_Nm = {0.05, -0.04, 0.03};
  const ModelSelection narrow = select_model(lumped_log(p, 33), test::least_squares());
  print(narrow);
  EXPECT_NE(narrow.variants[narrow.chosen].held_out_rmse_Nm, narrow.variants[0].held_out_rmse_Nm);
  EXPECT_FALSE(narrow.alike.empty()) << narrow.reason;
  const ModelSelection wide =
      select_model(lumped_log(p, 33, "pick-and-place"), test::least_squares());
  print(wide);
  EXPECT_FALSE(wide.variants[wide.chosen].model.per_joint);
  EXPECT_TRUE(wide.variants[wide.chosen].model.offsets);
}

// Physics the model does not contain: the multibody robot whose arms'
// masses (and inertias) differ by 5 %, and the same robot with equal arms.
// --model auto chooses per-joint arms only for the first, and there the
// held-out pick-and-place error falls by more than 25 %.
TEST(ModelSelectionTest, OnAMultibodyRobotArmsThatDifferChoosePerJointArms) {
  delta::RobotDescription equal = delta::default_robot_description();
  delta::RobotDescription differ = equal;
  for (const auto& [i, f] : {std::pair{0u, 1.05}, std::pair{2u, 0.95}}) {
    delta::UpperArmBody arm = equal.upper_arm;
    arm.mass_kg *= f;
    arm.inertia.xx_kg_m2 *= f;
    arm.inertia.yy_kg_m2 *= f;
    arm.inertia.zz_kg_m2 *= f;
    differ.arm_bodies[i] = arm;
  }
  const FitOptions ls = test::least_squares();
  const ModelSelection same = select_model(test::multibody_log(equal, 0.25), ls);
  print(same);
  EXPECT_FALSE(same.variants[same.chosen].model.per_joint);
  const DeltaLog fit_log_differ = test::multibody_log(differ, 0.25);
  const ModelSelection s = select_model(fit_log_differ, ls);
  print(s);
  EXPECT_TRUE(s.variants[s.chosen].model.per_joint);
  // Held out: a pick-and-place log of the same robot.
  const DeltaLog pnp = test::multibody_log(differ, 0.25, "pick-and-place", 9);
  FitOptions per_joint = ls;
  per_joint.model.per_joint = true;
  const auto shared_fit = fit_log(fit_log_differ, ls, {&pnp});
  const auto joint_fit = fit_log(fit_log_differ, per_joint, {&pnp});
  double shared_rmse = 0, joint_rmse = 0;
  for (unsigned j = 0; j < 3; ++j) {
    shared_rmse += shared_fit.validation[0].rmse_measured_Nm[j];
    joint_rmse += joint_fit.validation[0].rmse_measured_Nm[j];
  }
  std::cout << "  pick-and-place held out: shared " << shared_rmse / 3 << " N m, per-joint "
            << joint_rmse / 3 << " N m\n";
  EXPECT_LT(joint_rmse, 0.75 * shared_rmse);
}

// What a plain fit reports as its model's support comes from its own
// regression (the shared model's, slow rows last as a fit builds it): the
// same choice and held-out errors as select_model(), which preprocesses
// the log again with the largest variant, on logs where each variant wins.
TEST(ModelSelectionTest, ThePlainFitsJudgementFromItsOwnRowsIsSelectModels) {
  delta::LumpedParameters differ = delta::default_lumped_parameters();
  differ.arm_inertia_kg_m2[0] *= 1.05;
  differ.arm_gravity_moment_Nm[2] *= 1.05;
  delta::LumpedParameters offsets = delta::default_lumped_parameters();
  offsets.torque_offset_Nm = {0.05, -0.04, 0.03};
  const FitOptions ls = test::least_squares();
  for (const DeltaLog& log : {lumped_log(delta::default_lumped_parameters(), 35),
                              lumped_log(differ, 36), lumped_log(offsets, 37, "pick-and-place")}) {
    const ModelSelection reference = select_model(log, ls);
    const auto model = make_model(ls.model);
    PrepareOptions prepare = ls.prepare;
    prepare.slow_rows_last_below_rad_s = min_speed_for(ls);
    const Preprocessed pre = preprocess(*model, log, prepare);
    const ModelSelection own = judge_support(*model, ls.model, pre.regression, pre.fast_rows);
    print(own);
    EXPECT_EQ(own.chosen, reference.chosen);
    for (std::size_t v = 0; v < 4; ++v) {
      EXPECT_NEAR(own.variants[v].held_out_rmse_Nm, reference.variants[v].held_out_rmse_Nm,
                  1e-9 * reference.variants[v].held_out_rmse_Nm)
          << own.variants[v].name;
    }
  }
}

// The support's pass also sums each joint's Gram matrix of [Psi tau] over
// the equations (the fast rows, a slow joint's rows left out), and least
// squares given them solves as with its own pass: the matrices are the
// rows' own products, and the estimate, its cost and its standard
// deviations agree to rounding, unweighted and weighted by joint.
TEST(ModelSelectionTest, TheSupportsGramMatricesAreTheEquationsOwn) {
  const DeltaLog log = lumped_log(delta::default_lumped_parameters(), 35);
  FitOptions o;
  const auto model = make_model(o.model);
  PrepareOptions prepare;
  prepare.slow_rows_last_below_rad_s = 0.2;
  const Preprocessed pre = preprocess(*model, log, prepare);
  const Equations eq(pre.regression, pre.fast_rows);
  ASSERT_LT(eq.rows(), pre.regression.rows());
  JointGrams grams;
  judge_support(*model, o.model, pre.regression, pre.fast_rows, 5, 2, &grams);
  const Eigen::Index p = eq.psi.cols();
  for (unsigned j = 0; j < 3; ++j) {
    Eigen::MatrixXd rows(0, p + 1);
    for (std::size_t row = 0; row < eq.rows(); ++row) {
      if (eq.joint[row] != j) continue;
      rows.conservativeResize(rows.rows() + 1, Eigen::NoChange);
      rows.row(rows.rows() - 1) << eq.psi.row(static_cast<Eigen::Index>(row)),
          eq.tau(static_cast<Eigen::Index>(row));
    }
    const Eigen::MatrixXd own = rows.transpose() * rows;
    EXPECT_LT((grams.of_joint[j] - own).norm(), 1e-12 * own.norm()) << "joint " << j;
  }
  for (const LsWeights weights : {LsWeights::kNone, LsWeights::kJoint}) {
    const LeastSquaresResult pass =
        solve_least_squares(eq, model->parameters(), LsSolver::kQr, weights, log.name, 50, 2);
    const LeastSquaresResult given = solve_least_squares(eq, model->parameters(), LsSolver::kQr,
                                                         weights, log.name, 50, 2, &grams);
    EXPECT_LT((given.beta - pass.beta).norm(), 1e-12 * pass.beta.norm());
    EXPECT_NEAR(given.cost, pass.cost, 1e-12 * pass.cost);
    EXPECT_LT((given.std_dev - pass.std_dev).norm(), 1e-10 * pass.std_dev.norm());
    EXPECT_LT((given.psi_t_psi - pass.psi_t_psi).norm(), 1e-12 * pass.psi_t_psi.norm());
  }
}

// A smaller variant's columns are sums of the largest one's: its
// preprocessed regression is the superset's mapped, to rounding.
TEST(ModelSelectionTest, TheSharedModelsColumnsAreSumsOfThePerJointOnes) {
  const DeltaLog log = lumped_log(delta::default_lumped_parameters(), 34);
  ModelOptions big;
  big.per_joint = true;
  big.offsets = true;
  const auto big_model = make_model(big);
  const auto shared_model = make_model(ModelOptions{});
  const Preprocessed all = preprocess(*big_model, log, {});
  const Preprocessed shared = preprocess(*shared_model, log, {});
  const auto& b = big_model->parameters();
  const auto& s = shared_model->parameters();
  for (std::size_t c = 0; c < s.size(); ++c) {
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(all.regression.psi.rows());
    for (std::size_t k = 0; k < b.size(); ++k) {
      if (b[k].name == s[c].name || b[k].name.rfind(s[c].name + "_", 0) == 0) {
        sum += all.regression.psi.col(static_cast<Eigen::Index>(k));
      }
    }
    const Eigen::VectorXd direct = shared.regression.psi.col(static_cast<Eigen::Index>(c));
    EXPECT_LT((sum - direct).norm(), 1e-12 * (1.0 + direct.norm())) << s[c].name;
  }
}

}  // namespace
}  // namespace host_id
