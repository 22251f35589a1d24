// A payload's mass on a base fit (fit --base): the loaded log's torque
// left unexplained by the base model, regressed on the platform's mass.
#include "host_id/payload.hpp"

#include <gtest/gtest.h>

#include <iostream>

#include "delta/input_error.hpp"
#include "fit_fixtures.hpp"
#include "host_id/simulate.hpp"

namespace host_id {
namespace {

DeltaLog log_with(const delta::LumpedParameters& truth, std::uint64_t seed, double duration_s,
                  const std::string& trajectory = "fourier") {
  SimulateOptions o;
  o.seed = seed;
  o.torque_noise = 0.015;
  o.encoder_bits = 17;
  o.duration_s = duration_s;
  o.base_frequency_hz = 0.25;
  o.trajectory = trajectory;
  o.parameters = truth;
  DeltaLog log = simulate_log(o);
  log.name = "sim-" + std::to_string(seed);
  return log;
}

// The multibody robot with a 0.5 kg payload 20 mm below the platform's
// centre, on a 0.25 Hz Fourier path (1.5 % torque noise, 17-bit encoders).
DeltaLog loaded_multibody_log(const delta::RobotDescription& robot, double duration_s,
                              std::uint64_t seed) {
  SimulateOptions o;
  o.plant = SimulatedPlant::kMujoco;
  o.robot = robot;
  o.robot.payload.mass_kg = 0.5;
  o.robot.payload.com_m = {0.0, 0.0, -0.02};
  o.duration_s = duration_s;
  o.torque_noise = 0.015;
  o.encoder_bits = 17;
  o.base_frequency_hz = 0.25;
  o.seed = seed;
  DeltaLog log = simulate_log(o);
  log.name = "loaded";
  return log;
}

// A 0.5 kg payload, from a 10 s loaded log on a base fitted without it.
TEST(PayloadTest, AHalfKilogramPayloadComesOutWithinOneAndAHalfPerCent) {
  const delta::LumpedParameters unloaded = delta::default_lumped_parameters();
  delta::LumpedParameters loaded = unloaded;
  loaded.platform_mass_kg += 0.5;
  const FitOptions options = test::least_squares();
  const FitResult base = fit_log(log_with(unloaded, 41, 16.0), options);
  const auto model = make_model(options.model);
  for (const char* trajectory : {"fourier", "pick-and-place"}) {
    const PayloadResult p = fit_payload(*model, base.beta, log_with(loaded, 42, 10.0, trajectory),
                                        options.prepare, min_speed_for(options));
    std::cout << "[ payload ] " << trajectory << ": " << p.mass_kg << " kg +- " << p.std_dev_kg
              << " (truth 0.5); torque RMSE joint 1 " << p.rmse_base_Nm[0] << " -> "
              << p.rmse_payload_Nm[0] << " N m\n";
    EXPECT_NEAR(p.mass_kg, 0.5, 0.0075) << trajectory;
    EXPECT_GT(p.std_dev_kg, 0.0);
    EXPECT_LT(p.std_dev_kg, 0.0075);
    EXPECT_LT(p.rmse_payload_Nm[0], 0.5 * p.rmse_base_Nm[0]);
  }
  // The same robot unloaded: no payload.
  const PayloadResult none = fit_payload(*model, base.beta, log_with(unloaded, 43, 10.0),
                                         options.prepare, min_speed_for(options));
  EXPECT_NEAR(none.mass_kg, 0.0, 3.0 * none.std_dev_kg + 1e-3);
  // with_payload adds it to both platform masses.
  const Eigen::VectorXd b = with_payload(*model, base.beta, 0.5);
  EXPECT_NEAR(b(3) - base.beta(3), 0.5, 1e-12);
  EXPECT_NEAR(b(4) - base.beta(4), 0.5, 1e-12);
  EXPECT_EQ(b(0), base.beta(0));
}

// Physics the model does not contain: the multibody robot, its base fitted
// on 20 s of a Fourier path, then 10 s with a 0.5 kg payload 20 mm below
// the platform's centre.
TEST(PayloadTest, OnTheMultibodyRobotAHalfKilogramPayloadComesOutWithinOneAndAHalfPerCent) {
  const delta::RobotDescription robot = delta::default_robot_description();
  const FitOptions options = test::least_squares();
  const FitResult base = fit_log(test::multibody_log(robot), options);
  const DeltaLog log = loaded_multibody_log(robot, 10.0, 7);
  const auto model = make_model(options.model);
  const PayloadResult p =
      fit_payload(*model, base.beta, log, options.prepare, min_speed_for(options));
  std::cout << "[ payload ] multibody: " << p.mass_kg << " kg +- " << p.std_dev_kg
            << " (truth 0.5)\n";
  EXPECT_NEAR(p.mass_kg, 0.5, 0.0075);
}

TEST(PayloadTest, APaper14BaseIsRefused) {
  const FitOptions options = test::least_squares(test::model_named("paper14"));
  const auto model = make_model(options.model);
  const DeltaLog log = log_with(delta::default_lumped_parameters(), 44, 4.0);
  EXPECT_THROW(
      (void)fit_payload(*model, Eigen::VectorXd::Zero(static_cast<Eigen::Index>(model->size())),
                        log, options.prepare, 0.0),
      delta::InputError);
}

// The inverse use: a payload of known mass gives each joint's torque scale.
// Both logs' torques are scaled per joint, as wrong motor constants would
// scale them; the scale comes back, and the robot's parameters in true
// units (the unloaded platform mass).
TEST(PayloadTest, AKnownPayloadCalibratesEachJointsTorqueScale) {
  const delta::LumpedParameters unloaded = delta::default_lumped_parameters();
  delta::LumpedParameters loaded = unloaded;
  loaded.platform_mass_kg += 0.5;
  const FitOptions options = test::least_squares();
  const auto model = make_model(options.model);
  for (const std::array<double, 3> s :
       {std::array<double, 3>{1.0, 1.0, 1.0}, std::array<double, 3>{1.06, 0.95, 1.12}}) {
    DeltaLog u = log_with(unloaded, 51, 20.0);
    DeltaLog l = log_with(loaded, 52, 20.0, "pick-and-place");
    for (DeltaLog* log : {&u, &l}) {
      for (unsigned j = 0; j < 3; ++j) {
        for (double& tau : log->tau[j]) tau *= s[j];
      }
    }
    const TorqueScaleResult r =
        fit_torque_scale(*model, u, l, 0.5, options.prepare, min_speed_for(options));
    std::cout << "[ scale   ] truth " << s[0] << " " << s[1] << " " << s[2] << ": " << r.scale[0]
              << " " << r.scale[1] << " " << r.scale[2] << " (std " << r.scale_std[0] << ")\n";
    for (unsigned j = 0; j < 3; ++j) {
      EXPECT_NEAR(r.scale[j], s[j], 0.005 * s[j]) << j;
      EXPECT_GT(r.scale_std[j], 0.0);
      EXPECT_LT(std::abs(r.scale[j] - s[j]), 4.0 * r.scale_std[j] + 1e-4) << j;
    }
    for (std::size_t c = 0; c < model->size(); ++c) {
      const std::string& name = model->parameters()[c].name;
      if (name == "platform_mass" || name == "platform_weight_mass") {
        EXPECT_NEAR(r.beta(static_cast<Eigen::Index>(c)), unloaded.platform_mass_kg, 0.01) << name;
      }
    }
  }
  // The scale is as good as the mass given: 10 % too heavy, 10 % too small.
  const TorqueScaleResult heavy =
      fit_torque_scale(*model, log_with(unloaded, 51, 20.0), log_with(loaded, 52, 20.0), 0.55,
                       options.prepare, min_speed_for(options));
  EXPECT_NEAR(heavy.scale[0], 0.5 / 0.55, 0.01);
  EXPECT_THROW(fit_torque_scale(*model, log_with(unloaded, 53, 10.0), log_with(loaded, 54, 10.0),
                                0.0, options.prepare, min_speed_for(options)),
               delta::InputError);
}

// The same on the multibody robot (forearm rods as bodies, which no fitted
// model contains exactly), with the default delta model.
TEST(PayloadTest, OnTheMultibodyRobotAKnownPayloadCalibratesTheTorqueScale) {
  const delta::RobotDescription robot = delta::default_robot_description();
  const FitOptions options = test::least_squares(test::model_named("delta"));
  const std::array<double, 3> s{1.06, 0.95, 1.12};
  const auto scaled = [&](DeltaLog log) {
    for (unsigned j = 0; j < 3; ++j) {
      for (double& tau : log.tau[j]) tau *= s[j];
    }
    return log;
  };
  const DeltaLog with_payload = scaled(loaded_multibody_log(robot, 20.0, 8));
  const auto model = make_model(options.model);
  const TorqueScaleResult r =
      fit_torque_scale(*model, scaled(test::multibody_log(robot)), with_payload, 0.5,
                       options.prepare, min_speed_for(options));
  std::cout << "[ scale   ] multibody, truth 1.06 0.95 1.12: " << r.scale[0] << " " << r.scale[1]
            << " " << r.scale[2] << " (std " << r.scale_std[0] << ")\n";
  for (unsigned j = 0; j < 3; ++j) EXPECT_NEAR(r.scale[j], s[j], 0.01 * s[j]) << j;
}

}  // namespace
}  // namespace host_id
