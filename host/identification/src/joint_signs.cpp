#include "host_id/joint_signs.hpp"

#include <cmath>
#include <limits>
#include <sstream>

#include "delta/input_error.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/preprocess.hpp"

namespace host_id {

namespace {

// The delta model with per-joint arms: no term that could absorb a sign
// (offsets, torque gains).
ModelOptions plain_model() {
  ModelOptions m;
  m.name = "delta";
  m.per_joint = true;
  return m;
}

// The bounded optimum's cost of `log` under `model`; NaN where the log
// cannot be fitted so (a negated angle with no pose, say).
double cost_of(const Model& model, const DeltaLog& log, const PrepareOptions& prepare,
               unsigned threads, int negate_torque_of = -1) {
  try {
    Preprocessed pre = preprocess(model, log, prepare, threads);
    Regression& r = pre.regression;
    if (negate_torque_of >= 0) {
      for (std::size_t row = 0; row < r.rows(); ++row) {
        if (r.joint[row] == negate_torque_of) r.tau(static_cast<Eigen::Index>(row)) *= -1.0;
      }
    }
    return bounded_least_squares_cost(Equations(r), model.parameters(), log.name);
  } catch (const delta::InputError&) {
    return std::numeric_limits<double>::quiet_NaN();
  }
}

}  // namespace

std::optional<InvertedJoint> inverted_joint(const DeltaLog& log, const FitOptions& options) {
  const auto model = make_model(plain_model());
  const double as_logged = cost_of(*model, log, options.prepare, options.threads);
  if (!(as_logged > 0.0)) return std::nullopt;
  std::optional<InvertedJoint> best;
  auto consider = [&](unsigned j, bool angle, double cost) {
    if (!(cost * kInvertedJointRatio < as_logged)) return;
    if (best && !(cost < best->cost_negated_Nm2)) return;
    best = InvertedJoint{j, angle, as_logged, cost};
  };
  for (unsigned j = 0; j < 3; ++j) {
    consider(j, false, cost_of(*model, log, options.prepare, options.threads, static_cast<int>(j)));
    DeltaLog negated = log;
    for (double& q : negated.q[j]) q = -q;
    for (double& qd : negated.qd[j]) qd = -qd;
    for (double& qdd : negated.qdd[j]) qdd = -qdd;
    consider(j, true, cost_of(*model, negated, options.prepare, options.threads));
  }
  return best;
}

std::string inverted_joint_message(const InvertedJoint& j, const std::string& log_name) {
  const std::string n = std::to_string(j.joint + 1);
  const std::string column = (j.angle ? "q" : "tau") + n;
  std::ostringstream m;
  m << log_name << ": joint " << n << "'s " << (j.angle ? "angle" : "torque")
    << " looks opposite in sign to docs/conventions.md's: with " << column
    << " negated the model explains the log " << j.cost_as_logged_Nm2 / j.cost_negated_Nm2
    << " times better (cost " << j.cost_negated_Nm2 << " against " << j.cost_as_logged_Nm2
    << " N^2 m^2 as logged). Negate " << column
    << (j.angle ? " (and its encoder's direction in the drive's configuration)"
                : " (or the drive's torque scale)")
    << ": positive angles turn the arm down, positive torque pushes it down, and holding it "
       "against gravity takes negative torque";
  return m.str();
}

bool suspect_inverted_joint(const FitResult& r) {
  for (unsigned j = 0; j < 3; ++j) {
    if (r.fit.rmse_filtered_Nm[j] > kSuspectErrorShare * r.fit.rms_torque_Nm[j]) return true;
  }
  for (const ParameterEstimate& e : r.parameters) {
    if (e.info.name.rfind("torque_gain_gap_", 0) == 0 && e.value > 1.0) return true;
  }
  return false;
}

}  // namespace host_id
