// The fixed-point model (delta/fixed/dynamics.hpp) against the double one
// (delta/dynamics.hpp) at random states inside the workspace, up to the
// controller's default velocity and acceleration limits: the bar is 0.1 %
// of the default max torque (8 N m), and docs/design/fixed-point-core.md states the
// measured worst case.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "delta/dynamics.hpp"
#include "delta/fixed/dynamics.hpp"
#include "delta/kinematics.hpp"
#include "delta/model_q.hpp"
#include "delta/q_conversion.hpp"
#include "delta/splitmix.hpp"

namespace delta::fx {
namespace {

constexpr double kMaxTorqueNm = 8.0;

using delta::to_double;
using delta::to_q_saturated;

// A robot with every term of the model present and joints that differ.
HighFidelityParameters every_term() {
  HighFidelityParameters h;
  h.arm_inertia_kg_m2 = {7.2e-3, 7.5e-3, 6.9e-3};
  h.arm_gravity_cos_Nm = {0.441, 0.452, 0.430};
  h.arm_gravity_sin_Nm = {0.031, -0.02, 0.012};
  h.platform_inertial_mass_kg = 0.42;
  h.platform_weight_mass_kg = 0.40;
  h.forearm_coupling_kg = 0.05;
  h.viscous_friction_Nm_s_per_rad = {0.020, 0.025, 0.018};
  h.coulomb_friction_Nm = {0.060, 0.050, 0.070};
  h.stribeck_friction_Nm = {0.030, 0.020, 0.025};
  h.stribeck_velocity_rad_s = 0.1;
  h.torque_offset_Nm = {0.01, -0.02, 0.005};
  h.coulomb_smoothing_rad_s = 0.01;
  h.gravity_m_s2 = 9.81;
  return h;
}

// The parameters as the controller holds them (the conversion a loaded
// model goes through), and back: the double model then runs exactly the
// values the fixed-point one does.
ModelParametersQ parameters_q(const HighFidelityParameters& h) {
  IdentifiedModel m;
  m.kind = "delta";
  m.parameters = h;
  return model_parameters_q(m);
}

HighFidelityParameters as_held(const ModelParametersQ& m) {
  controller::ModelRecord r;
  r.parameters = m;
  return identified_model(r).parameters;
}

struct Worst {
  // torque_Nm: from the joint state alone; given_platform_Nm: with the
  // platform's position and acceleration given (a Cartesian trajectory's).
  double torque_Nm = 0.0, given_platform_Nm = 0.0, jacobian_m = 0.0, jdq_m_s2 = 0.0;
  int states = 0;
};

double uniform(SplitMix64& rng, double lo, double hi) {
  return lo + (hi - lo) * rng.uniform();
}

// The joint state at the angles of a workspace check, with speeds and
// accelerations drawn up to the limits given: in Q (sq) and the same
// values in double (sd).
void random_joint_state(const WorkspaceCheck<double>& ws, SplitMix64& rng, double max_speed_rad_s,
                        double max_acceleration_rad_s2, JointStateQ& sq, JointState& sd) {
  for (unsigned k = 0; k < 3; ++k) {
    sq.q_rad[k] = to_q_saturated<Q3_28>(ws.theta_rad[k]);
    sq.qd_rad_s[k] = to_q_saturated<Q10_21>(uniform(rng, -max_speed_rad_s, max_speed_rad_s));
    sq.qdd_rad_s2[k] =
        to_q_saturated<Q14_17>(uniform(rng, -max_acceleration_rad_s2, max_acceleration_rad_s2));
    sd.q_rad[k] = to_double(sq.q_rad[k]);
    sd.qd_rad_s[k] = to_double(sq.qd_rad_s[k]);
    sd.qdd_rad_s2[k] = to_double(sq.qdd_rad_s2[k]);
  }
}

// The velocity kinematics alone at the state's pose, in Q against double
// (their largest differences into w); and the state with the platform's
// position and acceleration given, as a Cartesian trajectory gives them.
JointStateQ state_with_platform_given(const Geometry& g, const GeometryQ& gq, const JointStateQ& sq,
                                      const JointState& sd, Worst& w) {
  const auto fk = forward_kinematics(g, sd.q_rad);
  const auto vk = velocity_kinematics(g, sd.q_rad, sd.qd_rad_s, fk.position_m);
  const Vec3Q pq{to_q_saturated<Q7_24>(fk.position_m.x), to_q_saturated<Q7_24>(fk.position_m.y),
                 to_q_saturated<Q7_24>(fk.position_m.z)};
  const VelocityKinematicsQ vq = velocity_kinematics(gq, sq.q_rad, sq.qd_rad_s, pq);
  EXPECT_EQ(vq.status, KinematicsStatus::kOk);
  const double jdq[3] = {vk.jacobian_dot_qdot.x, vk.jacobian_dot_qdot.y, vk.jacobian_dot_qdot.z};
  for (unsigned r = 0; r < 3; ++r) {
    for (unsigned c = 0; c < 3; ++c) {
      w.jacobian_m = std::max(w.jacobian_m,
                              std::abs(to_double(vq.jacobian_m_per_rad[r][c]) - vk.jacobian(r, c)));
    }
    w.jdq_m_s2 = std::max(w.jdq_m_s2, std::abs(to_double(vq.jacobian_dot_qdot_m_s2[r]) - jdq[r]));
  }
  JointStateQ given = sq;
  given.platform_known = true;
  given.platform_m = pq;
  for (unsigned r = 0; r < 3; ++r) {
    double pdd = jdq[r];
    for (unsigned c = 0; c < 3; ++c) pdd += vk.jacobian(r, c) * sd.qdd_rad_s2[c];
    given.platform_acceleration_m_s2[r] = to_q_saturated<Q10_21>(pdd);
  }
  return given;
}

// Random states: a platform position inside the workspace, its joint
// angles, and speeds and accelerations up to the limits given; states
// whose torques exceed max_torque_Nm (what the controller's drives could
// give) are left out.
Worst compare(const Geometry& g, const HighFidelityParameters& h, double max_speed_rad_s,
              double max_acceleration_rad_s2, int wanted, double max_torque_Nm = 1e9) {
  const GeometryQ gq = geometry_q(g);
  const ModelQ m = prepare_model(gq, parameters_q(h));
  const HighFidelityParameters held = as_held(m.parameters);
  SplitMix64 rng(42);
  Worst w;
  const double reach = g.upper_arm_length_m + g.forearm_length_m;
  for (int tries = 0; w.states < wanted && tries < 50 * wanted; ++tries) {
    const Vec3<double> p{uniform(rng, -0.6, 0.6) * reach, uniform(rng, -0.6, 0.6) * reach,
                         uniform(rng, -1.0, -0.2) * reach};
    const auto ws = check_workspace(g, p, WorkspaceLimits<double>{});
    if (ws.status != WorkspaceStatus::kInside) continue;
    JointStateQ sq;
    JointState sd;
    random_joint_state(ws, rng, max_speed_rad_s, max_acceleration_rad_s2, sq, sd);
    Joint3Q12_19 tq{};
    Joint3 td{};
    if (inverse_dynamics(g, held, sd, td) != KinematicsStatus::kOk) continue;
    if (std::max({std::abs(td[0]), std::abs(td[1]), std::abs(td[2])}) > max_torque_Nm) continue;
    EXPECT_EQ(model_torque(m, sq, tq), KinematicsStatus::kOk);
    ++w.states;
    for (unsigned k = 0; k < 3; ++k) {
      w.torque_Nm = std::max(w.torque_Nm, std::abs(to_double(tq[k]) - td[k]));
    }
    const JointStateQ given = state_with_platform_given(g, gq, sq, sd, w);
    EXPECT_EQ(model_torque(m, given, tq), KinematicsStatus::kOk);
    for (unsigned k = 0; k < 3; ++k) {
      w.given_platform_Nm = std::max(w.given_platform_Nm, std::abs(to_double(tq[k]) - td[k]));
    }
  }
  return w;
}

TEST(FixedDynamicsTest, AgreesWithTheDoubleModelInsideTheWorkspace) {
  const Worst w = compare(kDefaultGeometry, every_term(), 6.0, 150.0, 20000);
  std::printf(
      "fixed model over %d states (|qd| <= 6 rad/s, |qdd| <= 150 rad/s^2): worst torque "
      "%.3g N m (%.4f %% of 8 N m; %.3g N m with the platform's position and acceleration "
      "given), J %.3g m/rad, J'q' %.3g m/s^2\n",
      w.states, w.torque_Nm, 100.0 * w.torque_Nm / kMaxTorqueNm, w.given_platform_Nm, w.jacobian_m,
      w.jdq_m_s2);
  EXPECT_EQ(w.states, 20000);
  EXPECT_LE(w.torque_Nm, 1e-3 * kMaxTorqueNm);
  EXPECT_LE(w.given_platform_Nm, 1e-3 * kMaxTorqueNm);
  EXPECT_LE(w.jacobian_m, 1e-5);
  EXPECT_LE(w.jdq_m_s2, 1e-3);
}

TEST(FixedDynamicsTest, AgreesOnALargerRobotAtItsOwnSpeeds) {
  // A robot twice the default's size, heavier, at a quarter of the speed.
  const Geometry g{0.4, 0.92, 0.2, 0.07};
  HighFidelityParameters h = every_term();
  for (double& v : h.arm_inertia_kg_m2) v *= 16.0;
  for (double& v : h.arm_gravity_cos_Nm) v *= 8.0;
  h.platform_inertial_mass_kg *= 4.0;
  h.platform_weight_mass_kg *= 4.0;
  const Worst w = compare(g, h, 3.0, 40.0, 5000);
  std::printf("larger robot over %d states: worst torque %.3g N m (%.3g N m given the platform)\n",
              w.states, w.torque_Nm, w.given_platform_Nm);
  EXPECT_EQ(w.states, 5000);
  EXPECT_LE(w.torque_Nm, 1e-3 * kMaxTorqueNm);
  EXPECT_LE(w.given_platform_Nm, 1e-3 * kMaxTorqueNm);
}

TEST(FixedDynamicsTest, AgreesOnARobotWhoseForearmsAreShortAgainstItsArms) {
  // Upper arm + |base radius - platform radius| = 0.365 m, over 8 forearm
  // lengths: no ratio of the geometry limits the formats. Near its
  // singular poses this robot needs torques no drive gives: the states
  // compared are those within its max torque, 40 N m, and the bar is 0.1 %
  // of that.
  const Geometry g{0.3, 0.045, 0.035, 0.1};
  constexpr double kShortMaxTorqueNm = 40.0;
  const Worst w = compare(g, every_term(), 3.0, 40.0, 2000, kShortMaxTorqueNm);
  std::printf(
      "short forearms over %d states: worst torque %.3g N m (%.3g N m given the platform)\n",
      w.states, w.torque_Nm, w.given_platform_Nm);
  EXPECT_GE(w.states, 500);  // of 100 000 positions tried: its workspace is small
  EXPECT_LE(w.torque_Nm, 1e-3 * kShortMaxTorqueNm);
  EXPECT_LE(w.given_platform_Nm, 1e-3 * kShortMaxTorqueNm);
}

TEST(FixedDynamicsTest, TheLumpedModelIsTheCaseWithoutSinCouplingAndMassSplit) {
  LumpedParameters lumped = default_lumped_parameters();
  const Worst w = compare(kDefaultGeometry, to_high_fidelity(lumped), 6.0, 150.0, 2000);
  EXPECT_EQ(w.states, 2000);
  EXPECT_LE(w.torque_Nm, 1e-3 * kMaxTorqueNm);
  EXPECT_LE(w.given_platform_Nm, 1e-3 * kMaxTorqueNm);
}

// The drive train's torque gains and load friction (host_id fit's, which
// the controller runs): at every state the torque is the rigid model's y
// divided by 1 - gap - mu tanh(qd / w) sign y, as the fit's model solves it
// (in double here), within 1e-5 N m. (Without the terms the torque is y bit
// for bit: the golden vectors' model lines are unchanged.)
TEST(FixedDynamicsTest, TheDriveTrainDividesTheTorqueAsTheFitsModelSolvesIt) {
  const GeometryQ gq = geometry_q(kDefaultGeometry);
  const HighFidelityParameters h = every_term();
  ModelParametersQ with = parameters_q(h);
  const ModelQ rigid = prepare_model(gq, with);
  const double gap[3] = {0.0, 0.08, -0.06};
  const double mu[3] = {0.05, 0.0, 0.12};
  for (unsigned j = 0; j < 3; ++j) {
    with.torque_gain_gap[j] = to_q_saturated<Q1_30>(gap[j]);
    with.load_friction[j] = to_q_saturated<Q1_30>(mu[j]);
  }
  const ModelQ drive = prepare_model(gq, with);
  SplitMix64 rng(7);
  double worst = 0.0;
  int states = 0;
  for (int tries = 0; states < 2000 && tries < 100000; ++tries) {
    const Vec3<double> p{uniform(rng, -0.3, 0.3), uniform(rng, -0.3, 0.3),
                         uniform(rng, -0.6, -0.2)};
    const auto ws = check_workspace(kDefaultGeometry, p, WorkspaceLimits<double>{});
    if (ws.status != WorkspaceStatus::kInside) continue;
    JointStateQ sq;
    JointState sd;
    random_joint_state(ws, rng, 0.05 + 3.0 * (states % 2), 60.0, sq, sd);
    Joint3Q12_19 y{}, tau{};
    ASSERT_EQ(model_torque(rigid, sq, y), KinematicsStatus::kOk);
    ASSERT_EQ(model_torque(drive, sq, tau), KinematicsStatus::kOk);
    ++states;
    for (unsigned j = 0; j < 3; ++j) {
      const double yd = to_double(y[j]);
      const double gain =
          1.0 - gap[j] -
          mu[j] * std::tanh(sd.qd_rad_s[j] / h.coulomb_smoothing_rad_s) * (yd < 0.0 ? -1.0 : 1.0);
      worst = std::max(worst, std::abs(to_double(tau[j]) - yd / std::max(gain, 0.05)));
    }
  }
  std::printf("drive train over %d states: worst %.3g N m against the fit's formula\n", states,
              worst);
  EXPECT_EQ(states, 2000);
  EXPECT_LE(worst, 1e-5);
}

TEST(FixedDynamicsTest, RefusesPosesWithoutKinematics) {
  // Forearms as long as the arms: with every arm at acos(0.675) the
  // forearms lie flat (the parallel singularity): a hair above it the
  // determinant is below the limit. At 0 they cannot meet.
  const GeometryQ gq = geometry_q(Geometry{0.2, 0.2, 0.1, 0.035});
  const ModelQ m = prepare_model(gq, parameters_q(every_term()));
  JointStateQ s;
  const Q3_28 flat = to_q_saturated<Q3_28>(std::acos(0.67499));
  s.q_rad = {flat, flat, flat};
  Joint3Q12_19 tau{Q12_19::from(1.0), Q12_19::from(1.0), Q12_19::from(1.0)};
  EXPECT_EQ(model_torque(m, s, tau), KinematicsStatus::kSingular);
  EXPECT_EQ(tau[0].raw(), 0);
  s.q_rad = {};
  EXPECT_EQ(model_torque(m, s, tau), KinematicsStatus::kUnreachable);
}

}  // namespace
}  // namespace delta::fx
