// `host_id predict`: a fitted model's torque at every sample of a log that a
// fit would use (docs/using-the-model.md, "Predicting torques").
#pragma once

#include <Eigen/Dense>
#include <array>
#include <string>
#include <vector>

#include "host_id/delta_log.hpp"
#include "host_id/model.hpp"
#include "host_id/preprocess.hpp"

namespace host_id {

struct PredictedLog {
  // A delta-log/1 log: the input's metadata (and predicted_by, result,
  // model), seq and t of each kept sample, the states used (q, qd, qdd),
  // the measured tau, and the columns tau_model1..3.
  DeltaLog log;
  std::array<double, 3> rmse_measured_Nm{};  // tau against tau_model, per joint
  PreprocessReport report;
  std::vector<std::size_t> log_index;  // of each kept sample in the input log
};

// Samples a trim drops are left out, not invented. Throws delta::InputError
// naming the log and the sample's time where a pose has no kinematics.
// An elastic model (ModelOptions::gearbox_compliance_rad_per_Nm) predicts
// at the arm's angles (elasticity.hpp, arm_side_for_prediction): the states
// written are those.
PredictedLog predict_log(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                         const PrepareOptions& prepare, const std::string& result_name);
// The same at the log's angles as they are, elastic model or not.
PredictedLog predict_log_as_is(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                               const PrepareOptions& prepare, const std::string& result_name);

}  // namespace host_id
