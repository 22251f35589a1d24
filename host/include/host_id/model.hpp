// Identification models: tau = Psi(q, qd, qdd) beta, linear in beta.
//   delta   - the lumped-mass model with lambda resolved at every sample
//             (common/model/include/delta/dynamics.hpp), physical parameters.
//   paper14 - the paper's 14-coefficient regressor with constant lambda.
#pragma once

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
  std::string name{"delta"};  // "delta" or "paper14"
  bool per_joint{false};      // delta: arm inertia and gravity moment per joint
  bool offsets{false};        // delta: a torque offset per joint
  double coulomb_smoothing_rad_s{0.01};
};

class Model {
 public:
  virtual ~Model() = default;
  const ModelOptions& options() const { return options_; }
  const std::vector<ParameterInfo>& parameters() const { return parameters_; }
  std::size_t size() const { return parameters_.size(); }
  // Writes the three regressor rows of one sample (row-major, 3 x size()).
  // Returns kOk, or why the pose has no kinematics.
  virtual delta::KinematicsStatus rows(const delta::Geometry& g, double gravity_m_s2,
                                       const delta::JointState& s, double* out) const = 0;

 protected:
  explicit Model(ModelOptions o) : options_(std::move(o)) {}
  ModelOptions options_;
  std::vector<ParameterInfo> parameters_;
};

// Throws delta::InputError for an unknown model name or options that do not apply.
std::unique_ptr<Model> make_model(const ModelOptions& options);

// The delta model's parameter vector for known physical parameters, in the
// order of its parameters() (used to check a fit against the truth).
std::vector<double> delta_parameter_vector(const ModelOptions& options,
                                           const delta::LumpedParameters& p);

}  // namespace host_id
