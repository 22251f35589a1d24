// Choosing the model variant the data support (--model auto): held-out
// error over time blocks, on logs whose truth says which variant is right.
#include "host_id/model_selection.hpp"

#include <gtest/gtest.h>

#include <iostream>

#include "fit_fixtures.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/simulate.hpp"

namespace host_id {
namespace {

DeltaLog lumped_log(const delta::LumpedParameters& truth, std::uint64_t seed) {
  SimulateOptions o;
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
  ASSERT_EQ(s.variants.size(), 4u);
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

TEST(ModelSelectionTest, TorqueOffsetsAreChosenWhereTheLogHasThem) {
  delta::LumpedParameters p = delta::default_lumped_parameters();
  p.torque_offset_Nm = {0.05, -0.04, 0.03};
  const ModelSelection s = select_model(lumped_log(p, 33), test::least_squares());
  print(s);
  EXPECT_FALSE(s.variants[s.chosen].model.per_joint);
  EXPECT_TRUE(s.variants[s.chosen].model.offsets);
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
