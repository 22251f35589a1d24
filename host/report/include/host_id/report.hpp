// What `host_id fit` and `host_id validate` print and save: a readable text
// report and the same content as JSON (format host_id-result/1).
#pragma once

#include <Eigen/Dense>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "host_id/identify.hpp"

namespace host_id {

std::string text_report(const FitResult& r);
nlohmann::json json_report(const FitResult& r);
// The variants' held-out errors and the choice: every fit's "model_support"
// (--model auto chooses by it; results saved by an earlier host_id with
// --model auto also have a copy under "model_selection", which no reader
// needs).
nlohmann::json json_model_selection(const ModelSelection& s);

// A saved result, as read back by `host_id validate`.
struct SavedResult {
  ModelOptions model;
  // The robot it was fitted for; results saved before it was recorded
  // have none, and are not checked.
  std::optional<delta::Geometry> geometry;
  PrepareOptions prepare;
  Eigen::VectorXd beta;  // in the model's parameter order
  // The fitted log's motion ("fit": "ranges"); unknown in results saved
  // before it was recorded.
  MotionRanges excitation;
};

// Throws delta::InputError naming the file and the key that is missing or wrong.
SavedResult read_saved_result(const std::string& path);

// The RMSE table of validation runs, as text and JSON.
std::string text_rmse_table(const std::vector<LogRmse>& rows, const std::string& first_label);
// The paper's Table 2 over several fits of the same logs: the torque RMSE
// per joint of each model on each log, against the measured torque and
// against the filtered torque.
std::string text_table2(const std::vector<FitResult>& results);
nlohmann::json json_rmse(const LogRmse& r);

}  // namespace host_id
