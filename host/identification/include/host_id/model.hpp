// Identification models: tau = Psi(q, qd, qdd) beta, linear in beta.
//   delta   - the higher-fidelity model (the default): the arm's centre of
//             mass off its line, inertial and weight platform masses, the
//             forearm rods' coupling; lambda resolved at every sample
//             (common/model/include/delta/dynamics.hpp).
//   lumped  - point masses at elbow and platform, lambda resolved.
//   paper14 - the paper's 14-coefficient regressor with constant lambda.
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <string>
#include <vector>

#include "delta/dynamics.hpp"

namespace host_id {

struct ParameterInfo {
  std::string name;
  std::string unit;
  bool nonnegative{false};  // physical prior: inertias, masses, friction >= 0
  std::string meaning;
};

struct ModelOptions {
  std::string name{"delta"};  // "delta", "lumped" or "paper14"
  bool per_joint{false};      // delta, lumped: arm inertia and gravity per joint
  bool offsets{false};        // delta, lumped: a torque offset per joint
  double coulomb_smoothing_rad_s{0.01};
  // delta, lumped: > 0 adds a Stribeck term per joint,
  // exp(-(qd / stribeck_velocity)^2) tanh(qd / w); 0: none.
  double stribeck_velocity_rad_s{0.0};
  // The drive train's terms (delta, lumped), in the logged torque tau_j
  // itself (docs/model.md, "The drive train"):
  //   load_friction: gear friction that grows with the torque the gear
  //     carries, mu_j |tau_j| tanh(qd_j / w), one coefficient per joint;
  //   torque_gains: joints 2 and 3's torque constants relative to joint 1's,
  //     as delta_j tau_j (delta_j = 1 - k_j / k_1).
  // With either, the model's torque solves tau = Psi(q) beta + those terms
  // (Model::solve_torque).
  bool load_friction{false};
  bool torque_gains{false};
  // delta, lumped: each gearbox's compliance 1 / K, rad/(N m); all 0: rigid.
  // With it the model is the arm's at q - c tau (elasticity.hpp): the fit
  // and a prediction move the log's angles there first.
  delta::Joint3 gearbox_compliance_rad_per_Nm{};
  // delta, lumped: each joint's cogging, a torque periodic in the joint's
  // angle, a sin(n q) + b cos(n q) with n its periods per joint revolution
  // (the motor's periods per revolution times the gear ratio); 0: no
  // term at that joint (docs/model.md, "Cogging").
  delta::Joint3 cogging_periods_per_rev{};
  bool cogging() const {
    return cogging_periods_per_rev[0] != 0.0 || cogging_periods_per_rev[1] != 0.0 ||
           cogging_periods_per_rev[2] != 0.0;
  }
  bool elastic() const {
    return gearbox_compliance_rad_per_Nm[0] != 0.0 || gearbox_compliance_rad_per_Nm[1] != 0.0 ||
           gearbox_compliance_rad_per_Nm[2] != 0.0;
  }
};

// The most cogging periods per joint revolution a model takes (a motor's
// 50 periods through a 100:1 gear).
inline constexpr double kMaxCoggingPeriodsPerRev = 5000.0;

// The names --model takes, in the order the help lists them.
inline const std::vector<std::string>& model_names() {
  static const std::vector<std::string> names{"delta", "lumped", "paper14"};
  return names;
}

class Model {
 public:
  virtual ~Model() = default;
  const ModelOptions& options() const { return options_; }
  const std::vector<ParameterInfo>& parameters() const { return parameters_; }
  std::size_t size() const { return parameters_.size(); }
  // Writes the three regressor rows of one sample (row-major, 3 x size()).
  // Returns kOk, or why the pose has no kinematics.
  // tau_Nm: the logged torque at the sample, which the drive train's terms
  // (ModelOptions::load_friction, torque_gains) are written with; zeros
  // leave those terms 0 (a prediction, then solve_torque).
  virtual delta::KinematicsStatus rows(const delta::Geometry& g, double gravity_m_s2,
                                       const delta::JointState& s, const delta::Joint3& tau_Nm,
                                       double* out) const = 0;
  // The columns of the cogging terms (none: empty).
  virtual std::vector<std::size_t> cogging_columns() const { return {}; }
  // The columns of rows()'s terms in the logged torque (none: empty).
  virtual std::vector<std::size_t> torque_columns() const { return {}; }
  // The model's torque at joint j, given y = the joint's row written with a
  // zero torque, times beta: tau solves tau = y + (the torque terms at tau).
  // y itself for a model without such terms.
  virtual double solve_torque(unsigned /*joint*/, double y_Nm, double /*qd_rad_s*/,
                              const Eigen::VectorXd& /*beta*/) const {
    return y_Nm;
  }
  // The parameter vector, in the order of parameters(), of a robot with
  // known physical parameters (a lumped robot is the special case with no
  // sin term, no coupling and equal platform masses). Throws
  // delta::InputError for a model without physical parameters (paper14).
  virtual std::vector<double> parameter_vector(const delta::HighFidelityParameters& p) const = 0;
  // Where the friction's shape (coulomb_smoothing_rad_s,
  // stribeck_velocity_rad_s) enters joint j's row: the columns of its shape
  // terms, and their values at the joint's velocity qd, as rows() writes
  // them. Every other value of the rows is the same for any shape. Returns
  // how many (at most kMaxShapeTerms); 0 for a model without such terms.
  static constexpr std::size_t kMaxShapeTerms = 2;
  virtual std::size_t shape_terms(unsigned /*joint*/, double /*qd_rad_s*/, std::size_t* /*columns*/,
                                  double* /*values*/) const {
    return 0;
  }

 protected:
  explicit Model(ModelOptions o) : options_(std::move(o)) {}
  ModelOptions options_;
  std::vector<ParameterInfo> parameters_;
};

// Throws delta::InputError for an unknown model name or options that do not apply.
std::unique_ptr<Model> make_model(const ModelOptions& options);

// The model's parameter vector for known lumped parameters (tests and
// `fit --truth`): make_model(options)->parameter_vector(to_high_fidelity(p)).
std::vector<double> parameter_vector(const ModelOptions& options, const delta::LumpedParameters& p);

}  // namespace host_id
