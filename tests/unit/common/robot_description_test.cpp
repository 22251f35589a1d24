// The robot description file: the shipped example is the built-in default,
// every error names the file and the key, and the truths derived from it.
#include "delta/robot_description.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "delta/input_error.hpp"
#include "delta/read_file.hpp"
#include "scratch_directory.hpp"

namespace delta {
namespace {

const char* kExample = "docs/examples/robot.json";  // tests run in the repository

// The example with one change, written to a file; the reader's message.
std::string error_with(const std::function<void(nlohmann::json&)>& change) {
  nlohmann::json j = nlohmann::json::parse(read_whole_file(kExample));
  change(j);
  const std::string path =
      testsupport::process_scratch("robot_description_test").file("robot.json");
  std::ofstream(path) << j.dump(2);
  try {
    read_robot_description(path);
  } catch (const InputError& e) {
    std::string m = e.what();
    if (m.rfind(path, 0) == 0) m = "robot.json" + m.substr(path.size());
    return m;
  }
  return "";
}

TEST(RobotDescriptionTest, TheExampleIsTheBuiltInDefault) {
  const RobotDescription file = read_robot_description(kExample);
  const RobotDescription builtin = default_robot_description();
  EXPECT_EQ(file.name, builtin.name);
  EXPECT_EQ(file.geometry.forearm_length_m, builtin.geometry.forearm_length_m);
  EXPECT_EQ(file.rod_spacing_m, builtin.rod_spacing_m);
  EXPECT_EQ(file.upper_arm.mass_kg, builtin.upper_arm.mass_kg);
  EXPECT_EQ(file.upper_arm.com_m.z, builtin.upper_arm.com_m.z);
  EXPECT_EQ(file.upper_arm.inertia.yy_kg_m2, builtin.upper_arm.inertia.yy_kg_m2);
  EXPECT_EQ(file.rod.tube_mass_kg, builtin.rod.tube_mass_kg);
  EXPECT_EQ(file.platform.mass_kg, builtin.platform.mass_kg);
  for (unsigned i = 0; i < 3; ++i) {
    EXPECT_EQ(file.joints[i].armature_kg_m2(), builtin.joints[i].armature_kg_m2());
    EXPECT_EQ(file.joints[i].coulomb_friction_Nm, builtin.joints[i].coulomb_friction_Nm);
    EXPECT_EQ(file.joints[i].viscous_friction_Nm_s_per_rad,
              builtin.joints[i].viscous_friction_Nm_s_per_rad);
    EXPECT_EQ(file.joints[i].stribeck_friction_Nm, builtin.joints[i].stribeck_friction_Nm);
  }
}

TEST(RobotDescriptionTest, TheDefaultRobotsLumpedModelIsTheDefaultParameters) {
  const LumpedParameters truth = lumped_truth(default_robot_description());
  const LumpedParameters nominal = default_lumped_parameters();
  for (unsigned i = 0; i < 3; ++i) {
    EXPECT_NEAR(truth.arm_inertia_kg_m2[i], nominal.arm_inertia_kg_m2[i], 1e-3 * 7.2e-3);
    EXPECT_NEAR(truth.arm_gravity_moment_Nm[i], nominal.arm_gravity_moment_Nm[i],
                2e-3 * 0.441);  // 0.44145 against a rounded 0.441
    EXPECT_EQ(truth.viscous_friction_Nm_s_per_rad[i], nominal.viscous_friction_Nm_s_per_rad[i]);
    EXPECT_EQ(truth.coulomb_friction_Nm[i], nominal.coulomb_friction_Nm[i]);
  }
  EXPECT_NEAR(truth.platform_mass_kg, nominal.platform_mass_kg, 1e-12);
}

TEST(RobotDescriptionTest, TruthsWorkedByHand) {
  // Rod: 0.04 kg tube of radius 4 mm over 0.46 m, 5 g cups.
  const RodMassSplit s = rod_mass_split(default_robot_description().rod, 0.46);
  const double k = 0.04 * 0.004 * 0.004 / (2.0 * 0.46 * 0.46);
  EXPECT_NEAR(s.a_kg, 0.04 / 3.0 + k + 0.005, 1e-15);
  EXPECT_NEAR(s.b_kg, 0.04 / 6.0 - k, 1e-15);
  EXPECT_NEAR(s.elbow_weight_kg, 0.025, 1e-15);
  const HighFidelityParameters t = high_fidelity_truth(default_robot_description());
  // Arm about its axis: 1.1667e-3 + 0.35 (0.1^2 + 0.01^2); armature 5e-6 * 10^2;
  // two rods' A at the elbow, 0.2 m out.
  EXPECT_NEAR(t.arm_inertia_kg_m2[0],
              1.1667e-3 + 0.35 * (0.01 + 0.0001) + 5e-4 + 2.0 * s.a_kg * 0.04, 1e-15);
  EXPECT_NEAR(t.arm_gravity_cos_Nm[0], 9.81 * (0.35 * 0.1 + 0.05 * 0.2), 1e-14);
  EXPECT_NEAR(t.arm_gravity_sin_Nm[0], 9.81 * 0.35 * 0.01, 1e-15);
  EXPECT_NEAR(t.platform_weight_mass_kg, 0.25 + 6.0 * 0.025, 1e-15);
  EXPECT_NEAR(t.platform_inertial_mass_kg, 0.25 + 6.0 * (0.04 / 3.0 + k + 0.005), 1e-15);
  EXPECT_NEAR(t.forearm_coupling_kg, 2.0 * s.b_kg, 1e-15);
}

TEST(RobotDescriptionTest, EveryErrorNamesTheFileAndTheKey) {
  EXPECT_EQ(error_with([](auto& j) { j["upper_arm"]["mass_kg"] = -0.35; }),
            "robot.json: upper_arm.mass_kg: must be positive (got -0.35)");
  EXPECT_EQ(error_with([](auto& j) { j["forearm_rod"]["tube_mass_kg"] = -1; }),
            "robot.json: forearm_rod.tube_mass_kg: must not be negative (got -1)");
  EXPECT_EQ(error_with([](auto& j) { j["upper_arm"]["inertia_kg_m2"]["yy"] = -1e-3; }),
            "robot.json: upper_arm.inertia_kg_m2: not positive definite (smallest principal "
            "moment -0.001 kg m^2)");
  EXPECT_EQ(error_with([](auto& j) { j["upper_arm"]["inertia_kg_m2"]["xy"] = 2e-3; }),
            "robot.json: upper_arm.inertia_kg_m2: not positive definite (smallest principal "
            "moment -0.00148721 kg m^2)");
  EXPECT_EQ(error_with([](auto& j) { j["upper_arm"]["inertia_kg_m2"]["xx"] = 3e-3; }),
            "robot.json: upper_arm.inertia_kg_m2: no body has these principal moments "
            "(0.0011667 + 0.0011667 < 0.003 kg m^2)");
  EXPECT_EQ(error_with([](auto& j) { j["geometry"]["forearm_length_m"] = 0.05; }),
            "robot.json: geometry: the robot cannot be assembled with its arms horizontal");
  EXPECT_EQ(error_with([](auto& j) { j["geometry"]["forearm_length_m"] = -0.46; }),
            "robot.json: geometry: forearm_length_m must be a positive length, got -0.46");
  EXPECT_EQ(error_with([](auto& j) { j["geometry"].erase("rod_spacing_m"); }),
            "robot.json: geometry.rod_spacing_m: missing");
  EXPECT_EQ(error_with([](auto& j) { j["platform"]["mass"] = 1; }),
            "robot.json: platform.mass: unknown key");
  EXPECT_EQ(error_with([](auto& j) {
              j["platform"]["com_m"] = {0, 0};
            }),
            "robot.json: platform.com_m: must be an array of three numbers");
  EXPECT_EQ(error_with([](auto& j) { j["joints"][1]["gear_ratio"] = "ten"; }),
            "robot.json: joints[1].gear_ratio: must be a number");
  EXPECT_EQ(error_with([](auto& j) { j["joints"][2]["coulomb_friction_Nm"] = -0.1; }),
            "robot.json: joints[2].coulomb_friction_Nm: must not be negative (got -0.1)");
  EXPECT_EQ(error_with([](auto& j) {
              j["joints"] = nlohmann::json::array({1, 2});
            }),
            "robot.json: joints: must be one object (for all joints) or an array of three");
  EXPECT_EQ(error_with([](auto& j) { j["format"] = "delta-robot/2"; }),
            "robot.json: format: must be \"delta-robot/1\"");
}

// The drive train's keys: today's rigid, ideal drive when left out; each
// read as given; each refusal names the joint and the key.
TEST(RobotDescriptionTest, TheDriveTrainKeysAreReadAndChecked) {
  const RobotDescription plain = read_robot_description(kExample);
  EXPECT_FALSE(plain.joints[0].elastic());
  EXPECT_EQ(plain.joints[0].torque_constant_ratio, 1.0);
  const auto elastic = [](nlohmann::json& j) {
    for (auto& joint : j["joints"]) {
      joint["gearbox_stiffness_Nm_per_rad"] = 3000;
      joint["gearbox_damping_Nm_s_per_rad"] = 0.3;
    }
  };
  EXPECT_EQ(error_with(elastic), "");
  EXPECT_EQ(error_with([&](auto& j) {
              elastic(j);
              j["joints"][1].erase("gearbox_stiffness_Nm_per_rad");
              j["joints"][1].erase("gearbox_damping_Nm_s_per_rad");
            }),
            "robot.json: joints: gearbox_stiffness_Nm_per_rad: give all three joints an elastic "
            "gearbox or none (a robot's gearboxes are of one kind)");
  EXPECT_EQ(error_with([](auto& j) { j["joints"][0]["gearbox_damping_Nm_s_per_rad"] = 0.3; }),
            "robot.json: joints[0].gearbox_damping_Nm_s_per_rad: needs an elastic gearbox "
            "(gearbox_stiffness_Nm_per_rad above 0)");
  EXPECT_EQ(error_with([](auto& j) { j["joints"][2]["torque_constant_ratio"] = 0; }),
            "robot.json: joints[2].torque_constant_ratio: must be positive (got 0)");
  EXPECT_EQ(error_with([](auto& j) { j["joints"][1]["load_friction_coefficient"] = 1.2; }),
            "robot.json: joints[1].load_friction_coefficient: must lie in [0, 1) (got 1.2)");
  EXPECT_EQ(error_with([](auto& j) { j["joints"][0]["cogging_amplitude_Nm"] = 0.02; }),
            "robot.json: joints[0].cogging_periods_per_motor_rev: must be at least 1 with a "
            "cogging amplitude");
  EXPECT_EQ(error_with([](auto& j) { j["joints"][0]["current_filter_time_constant_s"] = -1; }),
            "robot.json: joints[0].current_filter_time_constant_s: must not be negative (got -1)");
}

// "limits": the controller's motion limits for this robot, each key
// optional; none in the example; checked as the controller checks them.
TEST(RobotDescriptionTest, TheLimitsAreOptionalAndChecked) {
  EXPECT_FALSE(read_robot_description(kExample).limits.any());
  EXPECT_EQ(error_with([](auto& j) {
              j["limits"] = {{"max_torque_Nm", 40}, {"min_rad", -1.0}};
            }),
            "");
  EXPECT_EQ(error_with([](auto& j) {
              j["limits"] = {{"max_torque_nm", 40}};
            }),
            "robot.json: limits.max_torque_nm: unknown key");
  EXPECT_EQ(error_with([](auto& j) {
              j["limits"] = {{"max_torque_Nm", 0}};
            }),
            "robot.json: limits.max_torque_Nm: must be positive (got 0)");
  EXPECT_EQ(error_with([](auto& j) {
              j["limits"] = {{"min_rad", 0.5}, {"max_rad", 0.5}};
            }),
            "robot.json: limits.min_rad: must be below limits.max_rad (0.5 >= 0.5)");
  EXPECT_EQ(error_with([](auto& j) {
              j["limits"] = {{"max_rad", 4}};
            }),
            "robot.json: limits.max_rad: must lie within (-pi, pi) rad (got 4)");
}

// Arms that differ: upper_arms gives arm i its own body (null: upper_arm's),
// which the truth follows per joint; its errors name the entry.
TEST(RobotDescriptionTest, ArmsThatDifferHaveTheirOwnBodiesAndTruths) {
  nlohmann::json j = nlohmann::json::parse(read_whole_file(kExample));
  nlohmann::json heavy = j["upper_arm"];
  heavy["mass_kg"] = 1.05 * heavy["mass_kg"].get<double>();
  j["upper_arms"] = nlohmann::json::array({heavy, nullptr, j["upper_arm"]});
  const std::string path = testsupport::process_scratch("robot_description_test").file("arms.json");
  std::ofstream(path) << j.dump(2);
  const RobotDescription d = read_robot_description(path);
  ASSERT_TRUE(d.arm_bodies[0].has_value());
  EXPECT_FALSE(d.arm_bodies[1].has_value());
  EXPECT_DOUBLE_EQ(d.arm(0).mass_kg, 1.05 * d.upper_arm.mass_kg);
  EXPECT_DOUBLE_EQ(d.arm(1).mass_kg, d.upper_arm.mass_kg);
  const LumpedParameters t = lumped_truth(d);
  EXPECT_NEAR(t.arm_gravity_moment_Nm[0] - t.arm_gravity_moment_Nm[1],
              d.gravity_m_s2 * 0.05 * d.upper_arm.mass_kg * d.upper_arm.com_m.x, 1e-12);
  EXPECT_EQ(t.arm_gravity_moment_Nm[1], t.arm_gravity_moment_Nm[2]);
  EXPECT_EQ(error_with([](auto& k) { k["upper_arms"] = nlohmann::json::array({nullptr}); }),
            "robot.json: upper_arms: must be an array of three arm bodies (null: upper_arm's)");
  EXPECT_EQ(error_with([](auto& k) {
              nlohmann::json bad = k["upper_arm"];
              bad["mass_kg"] = -1;
              k["upper_arms"] = nlohmann::json::array({nullptr, nullptr, bad});
            }),
            "robot.json: upper_arms[2].mass_kg: must be positive (got -1)");
  EXPECT_EQ(error_with([](auto& k) {
              nlohmann::json bad = k["upper_arm"];
              bad["colour"] = "red";
              k["upper_arms"] = nlohmann::json::array({bad, nullptr, nullptr});
            }),
            "robot.json: upper_arms[0].colour: unknown key");
}

TEST(RobotDescriptionTest, OneJointObjectServesAllThree) {
  EXPECT_EQ(error_with([](auto& j) {
              const auto first = j["joints"][0];
              j["joints"] = first;
            }),
            "");
}

TEST(RobotDescriptionTest, NotJsonNamesTheFile) {
  const std::string path = testsupport::process_scratch("robot_description_test").file("bad.json");
  std::ofstream(path) << "{ \"format\": ";
  try {
    read_robot_description(path);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ":1:13: not valid JSON", 0), 0u) << e.what();
  }
}

// A number no double holds is the library's out_of_range, not a parse
// error; it too is an InputError naming where (found by fuzz_robot_description).
TEST(RobotDescriptionTest, NumberOverflowNamesLineAndColumn) {
  const std::string path = testsupport::process_scratch("robot_description_test").file("big.json");
  std::ofstream(path)
      << "{\n  \"format\": \"delta-robot/1\",\n  \"platform\": {\"mass_kg\": 1e1667}\n}\n";
  try {
    read_robot_description(path);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              path + ":3:27: not valid JSON: number overflow parsing '1e1667'");
  }
}

}  // namespace
}  // namespace delta
