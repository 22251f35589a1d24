#include "host_id/truth.hpp"

namespace host_id {

namespace {

// The drive train's parameters (Model::torque_columns): a torque gain gap
// is 1 - k_j / k_1 (k: the torque constant's actual over nominal), a load
// friction coefficient is mu_j k_j / k_1 in joint 1's torque unit, as the
// fit writes the logged torques.
void drive_train_truth(const delta::RobotDescription& robot, std::map<std::string, double>& t) {
  const double k1 = robot.joints[0].torque_constant_ratio;
  for (unsigned j = 0; j < 3; ++j) {
    const delta::JointDrive& d = robot.joints[j];
    const std::string n = std::to_string(j + 1);
    if (t.count("load_friction_" + n) != 0) {
      t["load_friction_" + n] = d.load_friction_coefficient * d.torque_constant_ratio / k1;
    }
    if (t.count("torque_gain_gap_" + n) != 0) {
      t["torque_gain_gap_" + n] = 1.0 - d.torque_constant_ratio / k1;
    }
  }
}

}  // namespace

std::map<std::string, double> parameter_truth(const ModelOptions& options,
                                              const delta::RobotDescription& robot) {
  std::map<std::string, double> t;
  if (options.name == "paper14") return t;
  const auto model = make_model(options);
  const delta::HighFidelityParameters physical =
      options.name == "delta" ? delta::high_fidelity_truth(robot)
                              : delta::to_high_fidelity(delta::lumped_truth(robot));
  const std::vector<double> v = model->parameter_vector(physical);
  // The logged torques are the drive's: the physical torque over the
  // torque constant's ratio, joint 1's where the model has the torque
  // gains (the others' relative to it), the mean of the three's without.
  const auto& joints = robot.joints;
  const double unit = options.torque_gains
                          ? joints[0].torque_constant_ratio
                          : (joints[0].torque_constant_ratio + joints[1].torque_constant_ratio +
                             joints[2].torque_constant_ratio) /
                                3.0;
  for (std::size_t c = 0; c < v.size(); ++c) t[model->parameters()[c].name] = v[c] / unit;
  drive_train_truth(robot, t);
  return t;
}

}  // namespace host_id
