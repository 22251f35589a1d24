// Cogging: the model's columns, and the search of a fit's residual
// (cogging.hpp) on residuals made to order: a periodic torque of the
// joint's angle over white noise and a smooth model error, noise alone,
// and a joint that hardly moves.
#include "host_id/cogging.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <optional>
#include <random>
#include <vector>

#include "delta/input_error.hpp"
#include "host_id/identify.hpp"
#include "host_id/model.hpp"

namespace host_id {
namespace {

// A 20 s, 1 kHz Fourier-like motion of each joint (amplitude `swing`
// rad), with residual = cogging(q) + smooth error + noise; the track keeps
// every 12th sample, as angle_track does at 20 Hz.
struct Made {
  Prediction p;
  AngleTrack track;
};

Made residual_with(const delta::Joint3& cogging_Nm, const delta::Joint3& n, double noise_Nm,
                   double swing_rad = 0.25, unsigned seed = 1) {
  Made m;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_Nm);
  for (std::size_t k = 0; k < 20000; ++k) {
    const double t = 1e-3 * static_cast<double>(k);
    m.p.t_s.push_back(t);
    for (unsigned j = 0; j < 3; ++j) {
      const double w = 2.0 * std::numbers::pi * 0.4 * (1.0 + 0.1 * j);
      const double q = 0.2 + swing_rad * (0.7 * std::sin(w * t) + 0.3 * std::sin(3.0 * w * t + j));
      const double qd = swing_rad * w * (0.7 * std::cos(w * t) + 0.9 * std::cos(3.0 * w * t + j));
      const double smooth = 0.01 * std::sin(2.0 * q + 0.5);
      const double e = cogging_Nm[j] * std::sin(n[j] * q + 0.3 * j) + smooth + noise(rng);
      m.p.measured_Nm[j].push_back(1.0 + e);
      m.p.predicted_Nm[j].push_back(1.0);
      m.p.velocity_rad_s[j].push_back(qd);
      if (k % 12 == 0) {
        if (j == 0) m.track.t_s.push_back(t);
        m.track.q_rad[j].push_back(q);
      }
    }
  }
  return m;
}

TEST(CoggingTest, APeriodicResidualIsFoundWithItsPeriodAndAmplitude) {
  const Made m = residual_with({0.02, 0.02, 0.0}, {60.0, 45.0, 60.0}, 0.005);
  const std::optional<CoggingSearch> s = find_cogging(m.p, m.track, 20.0);
  ASSERT_TRUE(s);
  ASSERT_TRUE(s->found());
  EXPECT_NEAR(s->periods_per_rev[0], 60.0, 0.5);
  EXPECT_NEAR(s->periods_per_rev[1], 45.0, 0.5);
  EXPECT_EQ(s->periods_per_rev[2], 0.0);  // noise and the smooth error only
  EXPECT_NEAR(s->amplitude_Nm[0], 0.02, 0.002);
  EXPECT_NEAR(s->amplitude_Nm[1], 0.02, 0.002);
  EXPECT_GE(s->peak_ratio[0], kCoggingPeakRatio);
}

// Over many noise draws, no peak is taken for cogging.
TEST(CoggingTest, NoiseAndASmoothErrorAreNotCogging) {
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const Made m = residual_with({0.0, 0.0, 0.0}, {60.0, 60.0, 60.0}, 0.005, 0.25, seed);
    const std::optional<CoggingSearch> s = find_cogging(m.p, m.track, 20.0);
    ASSERT_TRUE(s);
    EXPECT_FALSE(s->found()) << "seed " << seed << ": " << s->periods_per_rev[0] << ", "
                             << s->periods_per_rev[1] << ", " << s->periods_per_rev[2];
  }
}

// A cogging too small to matter against the residual (a fifth of the
// noise's RMS) is not taken, however sharp its peak.
TEST(CoggingTest, ACoggingTooSmallToMatterIsNotTaken) {
  const Made m = residual_with({0.001, 0.001, 0.001}, {60.0, 60.0, 60.0}, 0.005);
  const std::optional<CoggingSearch> s = find_cogging(m.p, m.track, 20.0);
  ASSERT_TRUE(s);
  EXPECT_FALSE(s->found());
}

TEST(CoggingTest, JointsThatHardlyMoveCannotTell) {
  const Made m = residual_with({0.02, 0.02, 0.02}, {60.0, 60.0, 60.0}, 0.005, 0.02);
  EXPECT_FALSE(find_cogging(m.p, m.track, 20.0));
}

TEST(CoggingTest, TheModelsColumnsAreSinAndCosOfTheAngleTimesItsPeriods) {
  ModelOptions o;
  o.cogging_periods_per_rev = {60.0, 0.0, 45.5};
  const auto model = make_model(o);
  const std::vector<std::size_t> columns = model->cogging_columns();
  ASSERT_EQ(columns.size(), 4u);
  EXPECT_EQ(model->parameters()[columns[0]].name, "cogging_sin_1");
  EXPECT_EQ(model->parameters()[columns[3]].name, "cogging_cos_3");
  delta::JointState s;
  s.q_rad = {0.3, 0.2, 0.25};
  s.qd_rad_s = {0.5, -0.4, 0.3};
  std::vector<double> rows(3 * model->size());
  ASSERT_EQ(model->rows(delta::kDefaultGeometry, 9.81, s, {}, rows.data()),
            delta::KinematicsStatus::kOk);
  const std::size_t p = model->size();
  EXPECT_DOUBLE_EQ(rows[columns[0]], std::sin(60.0 * 0.3));
  EXPECT_DOUBLE_EQ(rows[columns[1]], std::cos(60.0 * 0.3));
  EXPECT_DOUBLE_EQ(rows[2 * p + columns[2]], std::sin(45.5 * 0.25));
  EXPECT_EQ(rows[p + columns[0]], 0.0);  // joint 1's term, joint 2's row
  // A model without cogging has none; paper14 refuses it, as do periods
  // out of range.
  EXPECT_TRUE(make_model(ModelOptions{})->cogging_columns().empty());
  o.name = "paper14";
  EXPECT_THROW(make_model(o), delta::InputError);
  ModelOptions bad;
  bad.cogging_periods_per_rev = {-1.0, 0.0, 0.0};
  EXPECT_THROW(make_model(bad), delta::InputError);
}

}  // namespace
}  // namespace host_id
