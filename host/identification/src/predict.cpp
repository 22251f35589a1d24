#include "host_id/predict.hpp"

#include <cmath>
#include <sstream>

#include "delta/input_error.hpp"
#include "host_id/elasticity.hpp"

namespace host_id {

namespace {

// The output log's frame: the input's metadata and geometry, no samples.
DeltaLog empty_like(const DeltaLog& log, const Model& model, const std::string& result_name) {
  DeltaLog out;
  out.name = log.name;
  out.geometry = log.geometry;
  out.gravity_m_s2 = log.gravity_m_s2;
  out.sample_rate_hz = log.sample_rate_hz;
  for (const auto& kv : log.metadata) {
    if (kv.first != "predicted_by" && kv.first != "result" && kv.first != "model") {
      out.metadata.push_back(kv);
    }
  }
  out.metadata.emplace_back("predicted_by", "host_id predict");
  out.metadata.emplace_back("result", result_name);
  out.metadata.emplace_back("model", model.options().name);
  out.has_qd = true;
  out.has_qdd = true;
  for (unsigned j = 0; j < 3; ++j) {
    out.extra_columns.emplace_back("tau_model" + std::to_string(j + 1), Series{});
  }
  return out;
}

[[noreturn]] void no_kinematics(const DeltaLog& log, std::size_t k) {
  std::ostringstream m;
  m << log.name << ": sample at t = " << log.t[k] << " s: joint angles (" << log.q[0][k] << ", "
    << log.q[1][k] << ", " << log.q[2][k] << ") rad have no forward kinematics for this geometry "
    << "(unreachable or singular pose)";
  throw delta::InputError(m.str());
}

}  // namespace

PredictedLog predict_log(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                         const PrepareOptions& prepare, const std::string& result_name) {
  if (!model.options().elastic()) return predict_log_as_is(model, beta, log, prepare, result_name);
  return predict_log_as_is(model, beta, arm_side_for_prediction(model, beta, log, prepare), prepare,
                           result_name);
}

PredictedLog predict_log_as_is(const Model& model, const Eigen::VectorXd& beta, const DeltaLog& log,
                               const PrepareOptions& prepare, const std::string& result_name) {
  const PreparedStates prepared = prepare_states(log, prepare);
  PredictedLog out;
  out.report = prepared.report;
  out.log_index = prepared.log_index;
  out.log = empty_like(log, model, result_name);
  DeltaLog& o = out.log;
  const std::size_t p = model.size();
  std::vector<double> rows(3 * p);
  std::array<double, 3> sum_sq{};
  for (std::size_t i = 0; i < prepared.states.size(); ++i) {
    const std::size_t k = prepared.log_index[i];
    const delta::JointState& s = prepared.states[i];
    // The drive train's terms are in the torque the model solves for, not
    // in the measured one: the rows are written with a zero torque.
    if (model.rows(log.geometry, log.gravity_m_s2, s, delta::Joint3{}, rows.data()) !=
        delta::KinematicsStatus::kOk) {
      no_kinematics(log, k);
    }
    o.t.push_back(log.t[k]);
    if (!log.seq.empty()) o.seq.push_back(log.seq[k]);
    for (unsigned j = 0; j < 3; ++j) {
      double y = 0.0;
      for (std::size_t c = 0; c < p; ++c) y += rows[j * p + c] * beta(static_cast<Eigen::Index>(c));
      const double tau_model = model.solve_torque(j, y, s.qd_rad_s[j], beta);
      o.q[j].push_back(s.q_rad[j]);
      o.qd[j].push_back(s.qd_rad_s[j]);
      o.qdd[j].push_back(s.qdd_rad_s2[j]);
      o.tau[j].push_back(log.tau[j][k]);
      o.extra_columns[j].second.push_back(tau_model);
      sum_sq[j] += std::pow(log.tau[j][k] - tau_model, 2);
    }
  }
  const double n = static_cast<double>(o.size());
  for (unsigned j = 0; j < 3; ++j) out.rmse_measured_Nm[j] = std::sqrt(sum_sq[j] / n);
  return out;
}

}  // namespace host_id
