// The multibody plant (MuJoCo) against the lumped model and against hand
// computations from the robot description; the plants' fault reports.
#include "delta/plant.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "delta/kinematics.hpp"
#include "delta/mujoco_plant.hpp"
#include "delta/path_follower.hpp"
#include "delta/trajectory.hpp"

namespace delta {
namespace {

FourierTrajectory test_path(const Geometry& g, unsigned long long seed = 7) {
  FourierTrajectory path;
  EXPECT_TRUE(make_fourier_excitation(g, {0.0, 0.0, -0.42}, 5, 0.2, 0.35, seed, path));
  return path;
}

// The default robot with each rod's mass at its two ends (massless tube)
// and the arm's centre of mass on the arm line: the lumped model is then
// exact, friction included (plain Coulomb with the lumped smoothing).
RobotDescription point_mass_robot() {
  RobotDescription d = default_robot_description();
  d.rod.elbow_cup_mass_kg += d.rod.tube_mass_kg / 2.0;
  d.rod.platform_cup_mass_kg += d.rod.tube_mass_kg / 2.0;
  d.rod.tube_mass_kg = 0.0;
  d.upper_arm.com_m.z = 0.0;
  for (JointDrive& j : d.joints) {
    j.stribeck_friction_Nm = 0.0;
    j.friction_smoothing_rad_s = 0.01;
  }
  return d;
}

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return std::sqrt(s / static_cast<double>(v.size()));
}

TEST(MujocoPlantTest, PointMassRodsAgreeWithTheLumpedModel) {
  const RobotDescription d = point_mass_robot();
  const LumpedParameters lumped = lumped_truth(d);
  MujocoPlant plant(d, {0.3, 0.3, 0.3});
  const FourierTrajectory path = test_path(d.geometry);
  std::vector<double> tau_lumped, diff;
  for (double t = 0.0; t < 5.0; t += 0.01) {
    const JointState s = path.at(t);
    Joint3 expected{};
    ASSERT_EQ(inverse_dynamics(d.geometry, lumped, s, expected), KinematicsStatus::kOk);
    const Joint3 got = plant.inverse_dynamics(s);
    for (unsigned j = 0; j < 3; ++j) {
      tau_lumped.push_back(expected[j]);
      diff.push_back(got[j] - expected[j]);
    }
  }
  double worst = 0.0;
  for (double x : diff) worst = std::max(worst, std::abs(x));
  std::cout << "RMS torque " << rms(tau_lumped) << " N m, largest difference " << worst << " N m\n";
  EXPECT_LT(worst, 1e-3 * rms(tau_lumped));
}

// The higher-fidelity model against the multibody robot it was derived for:
// rods with mass along their length, the arm's centre of mass below its line,
// the rotor's armature, and (with the Stribeck term and the robot's
// friction shape) its friction.
TEST(MujocoPlantTest, HigherFidelityModelIsExactForTheMultibodyRobot) {
  const RobotDescription d = default_robot_description();
  const HighFidelityParameters model = high_fidelity_truth(d);
  const LumpedParameters lumped = lumped_truth(d);
  MujocoPlant plant(d, {0.3, 0.3, 0.3});
  const FourierTrajectory path = test_path(d.geometry, 11);
  double worst = 0.0, worst_lumped = 0.0;
  std::vector<double> tau;
  for (double t = 0.0; t < 5.0; t += 0.01) {
    const JointState s = path.at(t);
    Joint3 expected{}, expected_lumped{};
    ASSERT_EQ(inverse_dynamics(d.geometry, model, s, expected), KinematicsStatus::kOk);
    ASSERT_EQ(inverse_dynamics(d.geometry, lumped, s, expected_lumped), KinematicsStatus::kOk);
    const Joint3 got = plant.inverse_dynamics(s);
    for (unsigned j = 0; j < 3; ++j) {
      tau.push_back(got[j]);
      worst = std::max(worst, std::abs(got[j] - expected[j]));
      worst_lumped = std::max(worst_lumped, std::abs(got[j] - expected_lumped[j]));
    }
  }
  std::cout << "RMS torque " << rms(tau) << " N m; largest difference: higher-fidelity model "
            << worst << " N m, lumped model " << worst_lumped << " N m\n";
  EXPECT_LT(worst, 1e-3 * rms(tau));
  // And the test can tell: the lumped model misses what the robot has.
  EXPECT_GT(worst_lumped, 2e-2 * rms(tau));
}

RobotDescription frictionless(RobotDescription d) {
  for (JointDrive& j : d.joints) {
    j.viscous_friction_Nm_s_per_rad = 0.0;
    j.coulomb_friction_Nm = 0.0;
    j.stribeck_friction_Nm = 0.0;
  }
  return d;
}

// Held by the constant torques that balance gravity at its start pose and
// set moving, the robot swings about it. A constant torque is conservative
// (potential -tau . q), so E - tau . q is constant up to the integrator and
// the soft constraints. Over 1 s, against the motion's kinetic energy scale:
// RK4 at 1/8 ms keeps it within 1e-4 (measured 7e-6); the default
// semi-implicit Euler at 1/2 ms stays within 1e-2 (measured 6e-3). With
// friction the energy only decreases.
double swing(const RobotDescription& d, double* largest_change, bool* only_decreases,
             MujocoSettings settings = {}) {
  const Joint3 q0{0.3, 0.45, 0.35};
  MujocoPlant plant(d, q0, settings);
  const Joint3 hold = plant.inverse_dynamics(JointState{q0, {}, {}});
  plant.place(JointState{q0, {1.5, -1.0, 0.8}, {}});
  const auto energy = [&] {
    const JointState s = plant.state();
    double e = plant.total_energy_J();
    for (unsigned j = 0; j < 3; ++j) e -= hold[j] * s.q_rad[j];
    return e;
  };
  const double e0 = energy();
  double previous = e0;
  *largest_change = 0.0;
  *only_decreases = true;
  double kinetic_scale = 0.0;
  for (int k = 0; k < 500; ++k) {
    EXPECT_EQ(plant.step(hold, 0.002), PlantStatus::kOk) << plant.fault();
    const double e = energy();
    *largest_change = std::max(*largest_change, std::abs(e - e0));
    *only_decreases = *only_decreases && e <= previous + 1e-7;
    previous = e;
    const JointState s = plant.state();
    for (unsigned j = 0; j < 3; ++j) {
      kinetic_scale = std::max(kinetic_scale, 0.5 * 0.0125 * s.qd_rad_s[j] * s.qd_rad_s[j]);
    }
  }
  std::cout << "energy " << e0 << " J, largest change " << *largest_change
            << " J, kinetic energy scale " << kinetic_scale << " J, constraint violation "
            << plant.max_constraint_violation_m() << " m\n";
  return kinetic_scale;
}

TEST(MujocoPlantTest, UnforcedFrictionlessMotionKeepsItsEnergy) {
  double change = 0.0;
  bool decreases = false;
  const RobotDescription d = frictionless(default_robot_description());
  const double scale = swing(d, &change, &decreases, {MujocoIntegrator::kRk4, 1.25e-4});
  EXPECT_GT(scale, 0.005);  // it did move
  EXPECT_LT(change, 1e-4 * scale);
  // Semi-implicit Euler's energy error grows with the step: the bounds
  // scale with it.
  const double euler_scale = swing(d, &change, &decreases);
  EXPECT_LT(change, 1e-2 * euler_scale);
  const double coarse_scale =
      swing(d, &change, &decreases, {MujocoIntegrator::kEuler, kMujocoCoarsestStep_s});
  EXPECT_LT(change, 2e-2 * coarse_scale);
}

TEST(MujocoPlantTest, WithFrictionEnergyOnlyDecreases) {
  double change = 0.0;
  bool decreases = false;
  swing(default_robot_description(), &change, &decreases);
  EXPECT_TRUE(decreases);
  EXPECT_GT(change, 1e-3);  // friction took a visible part
}

// The torques that hold the robot still, by hand from the description: the
// gradient of the potential energy of every body (arm centres of mass, each
// rod's centre of mass halfway along it with its cups at the ends, the
// platform), by central differences. The multibody plant holds the robot
// with them: its inverse dynamics give them, and under them it stays put.
Joint3 holding_torque_by_hand(const RobotDescription& d, const Joint3& q) {
  const auto potential = [&](const Joint3& qq) {
    const Geometry& g = d.geometry;
    const Vec3<double> p = forward_kinematics(g, qq).position_m;
    double v = (d.platform.mass_kg + d.payload.mass_kg) * p.z;
    for (int c = 0; c < 3; ++c) {
      const double th = qq[static_cast<unsigned>(c)];
      // Arm frame: x along the arm (down by theta), z up when theta = 0.
      const double com_height =
          -d.upper_arm.com_m.x * std::sin(th) + d.upper_arm.com_m.z * std::cos(th);
      v += d.upper_arm.mass_kg * com_height;
      const double elbow_z = elbow_position(g, c, th).z;
      const double rods = 2.0;
      v += rods * (d.rod.elbow_cup_mass_kg * elbow_z + d.rod.platform_cup_mass_kg * p.z +
                   d.rod.tube_mass_kg * 0.5 * (elbow_z + p.z));
    }
    return d.gravity_m_s2 * v;
  };
  Joint3 tau{};
  const double h = 1e-6;
  for (unsigned j = 0; j < 3; ++j) {
    Joint3 plus = q, minus = q;
    plus[j] += h;
    minus[j] -= h;
    tau[j] = (potential(plus) - potential(minus)) / (2.0 * h);
  }
  return tau;
}

TEST(MujocoPlantTest, StaticPoseHoldingTorquesMatchAHandComputation) {
  const RobotDescription d = default_robot_description();
  const Joint3 q{0.3, 0.55, 0.1};
  const Joint3 by_hand = holding_torque_by_hand(d, q);
  MujocoPlant plant(d, q);
  const Joint3 inverse = plant.inverse_dynamics(JointState{q, {}, {}});
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_LT(by_hand[j], 0.0);  // holding up takes negative torque
    EXPECT_NEAR(inverse[j], by_hand[j], 1e-6 * std::abs(by_hand[j])) << "joint " << j + 1;
  }
  for (int k = 0; k < 100; ++k) ASSERT_EQ(plant.step(by_hand, 0.002), PlantStatus::kOk);
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_NEAR(plant.state().q_rad[j], q[j], 1e-6) << "joint " << j + 1;
  }
}

// The plant following a Fourier path under the stiff PD controller, at
// 1 kHz: the torques applied at each sample.
std::vector<double> followed_torques(MujocoSettings settings, double* violation) {
  const RobotDescription d = default_robot_description();
  const FourierTrajectory path = test_path(d.geometry);
  MujocoPlant plant(d, path.at(0.0).q_rad, settings);
  plant.place(path.at(0.0));
  const PathFollower follower(d.geometry, lumped_truth(d));
  std::vector<double> torques;
  for (int k = 0; k < 3000; ++k) {
    Joint3 tau{};
    EXPECT_EQ(follower.torque(path.at(k * 1e-3), plant.state(), tau), KinematicsStatus::kOk);
    EXPECT_EQ(plant.step(tau, 1e-3), PlantStatus::kOk) << plant.fault();
    torques.insert(torques.end(), tau.begin(), tau.end());
  }
  *violation = plant.max_constraint_violation_m();
  return torques;
}

// At the default step and at the coarsest one (the emulator's).
TEST(MujocoPlantTest, ChainsStayClosedAndHalvingTheStepChangesTorquesByUnderAThousandth) {
  for (const double step_s : {MujocoSettings{}.max_step_s, kMujocoCoarsestStep_s}) {
    SCOPED_TRACE("step " + std::to_string(step_s) + " s");
    double violation = 0.0, violation_half = 0.0;
    const std::vector<double> tau =
        followed_torques({MujocoIntegrator::kEuler, step_s}, &violation);
    const std::vector<double> tau_half =
        followed_torques({MujocoIntegrator::kEuler, step_s / 2}, &violation_half);
    std::vector<double> diff(tau.size());
    for (std::size_t i = 0; i < tau.size(); ++i) diff[i] = tau[i] - tau_half[i];
    std::cout << "step " << step_s * 1e3 << " ms: RMS torque " << rms(tau)
              << " N m, RMS change with half the step " << rms(diff)
              << " N m; largest constraint violation " << violation * 1e6 << " um (half step "
              << violation_half * 1e6 << " um)\n";
    EXPECT_LT(rms(diff), 1e-3 * rms(tau));
    EXPECT_LT(violation, 20e-6);
    EXPECT_LT(violation_half, violation);
  }
}

TEST(MujocoPlantTest, FaultsInsteadOfDiverging) {
  // A torque no drive gives: the arms run away; the plant says so and stops.
  MujocoPlant plant(default_robot_description(), {0.3, 0.3, 0.3});
  PlantStatus st = PlantStatus::kOk;
  for (int k = 0; k < 500 && st == PlantStatus::kOk; ++k)
    st = plant.step({-500.0, 0.0, 0.0}, 0.002);
  EXPECT_NE(st, PlantStatus::kOk);
  EXPECT_FALSE(plant.fault().empty());
  std::cout << plant.fault() << "\n";
  EXPECT_NE(plant.step({}, 0.002), PlantStatus::kOk);  // and stays faulted
  for (double v : plant.state().qd_rad_s) EXPECT_EQ(v, 0.0);
}

TEST(LumpedPlantTest, FaultsInsteadOfDiverging) {
  LumpedPlant plant(kDefaultGeometry, default_lumped_parameters(), {0.45, 0.45, 0.45});
  PlantStatus st = PlantStatus::kOk;
  for (int k = 0; k < 2000 && st == PlantStatus::kOk; ++k) st = plant.step({3.0, 3.0, 3.0}, 0.002);
  EXPECT_NE(st, PlantStatus::kOk);
  EXPECT_FALSE(plant.fault().empty());
  std::cout << plant.fault() << "\n";
  for (unsigned j = 0; j < 3; ++j) EXPECT_TRUE(std::isfinite(plant.state().q_rad[j]));
}

}  // namespace
}  // namespace delta

namespace delta {
namespace {

// A force on the platform (a contact) reaches the joints through the
// closed chains: held at rest by the torques of its inverse dynamics, the
// robot does not move until 10 N push the platform down, and then every
// arm turns down (positive angles, docs/conventions.md); 20 N turn them
// twice as fast, and 10 N up the other way.
TEST(MujocoPlantTest, APlatformForceTurnsTheArmsAsTheChainsCarryIt) {
  const RobotDescription robot = default_robot_description();
  const JointState rest{{0.4, 0.45, 0.5}, {}, {}};
  const auto qdd_under = [&](double force_z_N) {
    MujocoPlant plant(robot, rest.q_rad);
    const Joint3 hold = plant.inverse_dynamics(rest);
    EXPECT_TRUE(plant.set_platform_force({0.0, 0.0, force_z_N}));
    EXPECT_EQ(plant.step(hold, 1e-3), PlantStatus::kOk);
    return plant.state().qdd_rad_s2;
  };
  const Joint3 none = qdd_under(0.0), down = qdd_under(-10.0), twice = qdd_under(-20.0),
               up = qdd_under(10.0);
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_LT(std::abs(none[j]), 0.05 * std::abs(down[j])) << j;
    EXPECT_GT(down[j], 1.0) << j;
    EXPECT_NEAR(twice[j] - none[j], 2.0 * (down[j] - none[j]), 0.05 * std::abs(down[j])) << j;
    EXPECT_NEAR(up[j] - none[j], -(down[j] - none[j]), 0.05 * std::abs(down[j])) << j;
  }
}

}  // namespace
}  // namespace delta
