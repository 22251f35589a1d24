// The drive train (delta/drive_train_plant.hpp) against the physics it
// stands for: the static deflection of an elastic gearbox is tau / K, its
// resonance sits at sqrt(K (1/J_motor + 1/J_arm)), the torque scale and
// cogging and load friction follow their laws, and the current filter has
// the phase of a first-order lag. Most tests put the drive train on a fake
// arm plant, one rigid inertia per joint whose motion is exact; the static
// deflection also holds on the multibody robot.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "delta/drive_train_plant.hpp"
#include "delta/mujoco_plant.hpp"

namespace delta {
namespace {

// Three uncoupled rigid arms under torques held over a step, integrated as
// MuJoCo's semi-implicit Euler does (velocity first, then position).
class InertiaArms final : public Plant {
 public:
  explicit InertiaArms(double inertia_kg_m2) : inertia_(inertia_kg_m2) {}
  PlantStatus step(const Joint3& tau_Nm, double dt_s) override {
    last_tau_ = tau_Nm;
    for (unsigned j = 0; j < 3; ++j) {
      const double a = tau_Nm[j] / inertia_;
      s_.qd_rad_s[j] += a * dt_s;
      s_.q_rad[j] += s_.qd_rad_s[j] * dt_s;
      s_.qdd_rad_s2[j] = a;
    }
    return PlantStatus::kOk;
  }
  void stop() override { s_.qd_rad_s = {}; }
  JointState state() const override { return s_; }
  const std::string& fault() const override { return none_; }
  const Joint3& last_torque() const { return last_tau_; }

 private:
  double inertia_;
  JointState s_{};
  Joint3 last_tau_{};
  std::string none_;
};

JointDrive frictionless_drive() {
  JointDrive j;
  j.rotor_inertia_kg_m2 = 5e-6;
  j.gear_ratio = 10.0;
  j.friction_smoothing_rad_s = 0.02;
  return j;
}

std::array<JointDrive, 3> three(const JointDrive& j) {
  return {j, j, j};
}

// The twist of joint 1 after a torque step, sampled every `step_s` for
// `duration_s`.
std::vector<double> free_twist(const JointDrive& j, double arm_kg_m2, double step_s,
                               double duration_s) {
  DriveTrainPlant plant(std::make_unique<InertiaArms>(arm_kg_m2), three(j));
  EXPECT_EQ(plant.step({0.5, 0.0, 0.0}, 1e-3), PlantStatus::kOk);
  std::vector<double> twist;
  for (double t = 0.0; t < duration_s; t += step_s) {
    EXPECT_EQ(plant.step({}, step_s), PlantStatus::kOk);
    twist.push_back(plant.state().q_rad[0] - plant.arm_state().q_rad[0]);
  }
  return twist;
}

// The mean period from the upward zero crossings about the mean.
double mean_period_s(const std::vector<double>& v, double step_s) {
  double mean = 0.0;
  for (double x : v) mean += x / static_cast<double>(v.size());
  std::vector<double> crossings;
  for (std::size_t k = 1; k < v.size(); ++k) {
    const double a = v[k - 1] - mean, b = v[k] - mean;
    if (a < 0.0 && b >= 0.0) crossings.push_back((static_cast<double>(k) - b / (b - a)) * step_s);
  }
  EXPECT_GE(crossings.size(), 10u);
  return (crossings.back() - crossings.front()) / static_cast<double>(crossings.size() - 1);
}

double peak_to_peak(const std::vector<double>& v, std::size_t from, std::size_t to) {
  const auto [lo, hi] = std::minmax_element(v.begin() + static_cast<std::ptrdiff_t>(from),
                                            v.begin() + static_cast<std::ptrdiff_t>(to));
  return *hi - *lo;
}

TEST(DriveTrainTest, AnElasticGearboxResonatesAtItsTwoMassFrequency) {
  JointDrive j = frictionless_drive();
  j.gearbox_stiffness_Nm_per_rad = 3000.0;
  constexpr double kArm = 0.02;
  const double expected_hz =
      std::sqrt(3000.0 * (1.0 / j.armature_kg_m2() + 1.0 / kArm)) / (2.0 * std::numbers::pi);
  // Sampled finely, and at the arm's own step (two motor sub-steps each).
  for (const double step_s : {1e-4, DriveTrainPlant::kArmStepElastic_s}) {
    SCOPED_TRACE(step_s);
    const std::vector<double> twist = free_twist(j, kArm, step_s, 0.2);
    EXPECT_NEAR(1.0 / mean_period_s(twist, step_s), expected_hz, 0.01 * expected_hz);
    // Next to no numerical damping or growth: as a damping ratio, under
    // 0.2 % of critical (a real gearbox's is some per cent), from the
    // amplitude's change over the 0.16 s between the first and last fifth.
    const std::size_t n = twist.size();
    const double change =
        std::log(peak_to_peak(twist, n - n / 5, n) / peak_to_peak(twist, 0, n / 5));
    const double cycles = 0.16 * expected_hz;
    EXPECT_LT(std::abs(change) / (2.0 * std::numbers::pi * cycles), 0.002) << change;
  }
}

TEST(DriveTrainTest, TheStaticDeflectionOfTheMultibodyRobotIsItsGearTorqueOverTheStiffness) {
  RobotDescription d = default_robot_description();
  for (JointDrive& j : d.joints) {
    j.gearbox_stiffness_Nm_per_rad = 2500.0;
    j.gearbox_damping_Nm_s_per_rad = 0.5;
  }
  const Joint3 q0{0.3, 0.4, 0.5};
  auto arms = std::make_unique<MujocoPlant>(arms_only(d), q0);
  MujocoPlant& arm_plant = *arms;
  const Joint3 gravity = arm_plant.inverse_dynamics(JointState{q0, {}, {}});
  DriveTrainPlant plant(std::move(arms), d.joints);
  // The motors held by a stiff PD on their own encoders at q0 plus the
  // deflection the gravity torque needs, with the gravity torque fed
  // forward: the arms settle at q0.
  for (int k = 0; k < 1500; ++k) {
    const JointState m = plant.state();
    Joint3 tau{};
    for (unsigned j = 0; j < 3; ++j) {
      const double target = q0[j] + gravity[j] / 2500.0;
      tau[j] = gravity[j] + 200.0 * (target - m.q_rad[j]) - 2.0 * m.qd_rad_s[j];
    }
    ASSERT_EQ(plant.step(tau, 2e-3), PlantStatus::kOk) << plant.fault();
  }
  const Joint3 gear = plant.gear_torque_Nm();
  for (unsigned j = 0; j < 3; ++j) {
    const double deflection = plant.state().q_rad[j] - plant.arm_state().q_rad[j];
    EXPECT_NEAR(gear[j], gravity[j], 1e-3 * std::abs(gravity[j])) << "joint " << j + 1;
    EXPECT_NEAR(deflection, gravity[j] / 2500.0, 1e-3 * std::abs(gravity[j] / 2500.0))
        << "joint " << j + 1;
    EXPECT_NEAR(plant.arm_state().q_rad[j], q0[j], 1e-5) << "joint " << j + 1;
  }
}

TEST(DriveTrainTest, TheTorqueConstantScalesWhatTheArmGets) {
  JointDrive j = frictionless_drive();
  j.torque_constant_ratio = 1.08;
  auto arms = std::make_unique<InertiaArms>(0.02);
  InertiaArms& fake = *arms;
  DriveTrainPlant plant(std::move(arms), three(j));
  ASSERT_EQ(plant.step({1.0, -2.0, 0.5}, 1e-3), PlantStatus::kOk);
  EXPECT_DOUBLE_EQ(fake.last_torque()[0], 1.08);
  EXPECT_DOUBLE_EQ(fake.last_torque()[1], -2.16);
  EXPECT_DOUBLE_EQ(fake.last_torque()[2], 0.54);
}

TEST(DriveTrainTest, CoggingAndLoadFrictionFollowTheirLaws) {
  JointDrive j = frictionless_drive();
  j.cogging_amplitude_Nm = 0.03;
  j.cogging_periods_per_motor_rev = 6.0;
  j.load_friction_coefficient = 0.1;
  auto arms = std::make_unique<InertiaArms>(0.02);
  InertiaArms& fake = *arms;
  DriveTrainPlant plant(std::move(arms), three(j));
  // Move the arms first, so that angle and speed differ from zero.
  ASSERT_EQ(plant.step({2.0, -3.0, 1.0}, 0.05), PlantStatus::kOk);
  const JointState s = plant.state();
  const Joint3 tau{1.5, -0.7, 0.0};
  ASSERT_EQ(plant.step(tau, 1e-3), PlantStatus::kOk);
  for (unsigned k = 0; k < 3; ++k) {
    const double cog = 0.03 * std::sin(6.0 * 10.0 * s.q_rad[k]);
    const double load = 0.1 * std::abs(tau[k]) * std::tanh(s.qd_rad_s[k] / 0.02);
    EXPECT_NEAR(fake.last_torque()[k], tau[k] + cog - load, 1e-12) << "joint " << k + 1;
  }
}

TEST(DriveTrainTest, LoadFrictionOnTheMotorSideGrowsWithTheGearTorque) {
  // Elastic, the motor spinning at a steady speed against a twisted
  // spring: what brakes it beyond the spring is the load friction.
  JointDrive j = frictionless_drive();
  j.gearbox_stiffness_Nm_per_rad = 3000.0;
  j.load_friction_coefficient = 0.2;
  auto arms = std::make_unique<InertiaArms>(1e6);  // an arm that does not move
  DriveTrainPlant plant(std::move(arms), three(j));
  plant.place_motors(JointState{{}, {2.0, 2.0, 2.0}, {}}, {1.0, 1.0, 1.0});
  const double gear0 = plant.gear_torque_Nm()[0];
  const double v0 = plant.state().qd_rad_s[0];
  ASSERT_EQ(plant.step({}, 1e-5), PlantStatus::kOk);
  const double decel = (plant.state().qd_rad_s[0] - v0) / 1e-5;
  // J a = -gear - mu |gear| tanh(v / v_w), to the first order in the step.
  const double expected =
      (-gear0 - 0.2 * std::abs(gear0) * std::tanh(v0 / 0.02)) / j.armature_kg_m2();
  EXPECT_NEAR(decel, expected, 0.01 * std::abs(expected));
}

TEST(DriveTrainTest, TheCurrentFilterHasTheGainAndPhaseOfAFirstOrderLag) {
  const double tau_s = 5e-4, f_hz = 200.0, dt = 1e-5;
  CurrentFilter filter(tau_s);
  double in_phase = 0.0, quadrature = 0.0, t = 0.0;
  const double w = 2.0 * std::numbers::pi * f_hz;
  const int settle = 20000, n = 50000;  // 0.2 s to settle, then 100 periods
  for (int k = 0; k < settle + n; ++k) {
    t = k * dt;
    const double y = filter.update(std::sin(w * t), dt);
    if (k >= settle) {
      in_phase += y * std::sin(w * t);
      quadrature += y * std::cos(w * t);
    }
  }
  const double phase = std::atan2(quadrature, in_phase);
  const double gain = 2.0 * std::hypot(in_phase, quadrature) / n;
  // Sample k's input is held over the step that ends at t_k: on average
  // it leads by half a step, so the lag is half a step less than the
  // continuous filter's.
  EXPECT_NEAR(phase, -std::atan(w * tau_s) + w * dt / 2.0, 2e-4);
  EXPECT_NEAR(gain, 1.0 / std::sqrt(1.0 + w * w * tau_s * tau_s), 2e-3);
}

TEST(DriveTrainTest, ARobotWithoutDriveTrainEffectsNeedsNone) {
  EXPECT_FALSE(has_drive_train_effects(default_robot_description()));
  RobotDescription d = default_robot_description();
  d.joints[1].torque_constant_ratio = 0.95;
  EXPECT_TRUE(has_drive_train_effects(d));
}

}  // namespace
}  // namespace delta
