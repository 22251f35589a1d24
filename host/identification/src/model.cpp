#include "host_id/model.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "delta/input_error.hpp"
#include "delta/model_terms.hpp"

namespace host_id {

namespace {

using Term = delta::ModelTerm;
using B = delta::DynamicsBasis;

// A model linear in physical parameters, one column (or three) per term.
class PhysicalModel final : public Model {
 public:
  explicit PhysicalModel(ModelOptions o) : Model(std::move(o)) {
    const auto terms = delta::physical_model_terms(
        options_.name, options_.stribeck_velocity_rad_s > 0.0, options_.offsets);
    for (const Term& t : terms) {
      const bool per_joint = delta::term_per_joint(t, options_.per_joint);
      columns_.push_back({t, parameters_.size(), per_joint});
      for (unsigned j = 0; j < (per_joint ? 3u : 1u); ++j) {
        const std::string all = t.sharing == delta::TermSharing::kArm ? " (all arms)" : "";
        parameters_.push_back(
            {delta::term_parameter_name(t, per_joint, j), t.unit, t.nonnegative, t.meaning + all});
      }
    }
    plan_rows();
  }

  delta::KinematicsStatus rows(const delta::Geometry& g, double gravity_m_s2,
                               const delta::JointState& s, double* out) const override {
    delta::DynamicsBasis b;
    const auto status = delta::dynamics_basis(g, s, gravity_m_s2, options_.coulomb_smoothing_rad_s,
                                              b, options_.stribeck_velocity_rad_s);
    if (status != delta::KinematicsStatus::kOk) return status;
    rows_of(b, out);
    return delta::KinematicsStatus::kOk;
  }

  std::size_t shape_terms(unsigned joint, double qd_rad_s, std::size_t* columns,
                          double* values) const override {
    const delta::FrictionShapeTerms shape = delta::friction_shape_terms(
        qd_rad_s, options_.coulomb_smoothing_rad_s, options_.stribeck_velocity_rad_s);
    std::size_t n = 0;
    for (const Column& c : columns_) {
      const bool coulomb = c.term.basis == &B::coulomb;
      if (!coulomb && c.term.basis != &B::stribeck) continue;
      columns[n] = c.first + (c.per_joint ? joint : 0);
      values[n++] = coulomb ? shape.coulomb : shape.stribeck;
    }
    return n;
  }

  std::vector<double> parameter_vector(const delta::HighFidelityParameters& h) const override {
    std::vector<double> v;
    for (const Column& c : columns_) {
      if (c.term.robot_value != nullptr) {
        v.push_back(h.*(c.term.robot_value));
        continue;
      }
      const delta::Joint3& joint = h.*(c.term.joint_value);
      if (c.per_joint) {
        v.insert(v.end(), joint.begin(), joint.end());
      } else {
        v.push_back((joint[0] + joint[1] + joint[2]) / 3.0);
      }
    }
    return v;
  }

 private:
  struct Column {
    Term term;
    std::size_t first;  // its first column in the regressor
    bool per_joint;
  };
  // The three rows (row-major) of a sample with basis b, as the plan says.
  void rows_of(const delta::DynamicsBasis& b, double* out) const {
    const std::size_t p = size();
    std::fill_n(out, 3 * p, 0.0);
    for (const Entry& e : entries_) out[e.at] = (b.*(e.term))[e.joint];
    for (const std::size_t at : ones_) out[at] = 1.0;
  }
  // Where rows_of() puts the basis: term[joint] at out[at] (joint j's row
  // starts at j p); 1 at each of ones_; 0 elsewhere. From columns_, once.
  struct Entry {
    std::size_t at;
    delta::Joint3 B::*term;
    unsigned joint;
  };
  void plan_rows() {
    for (unsigned j = 0; j < 3; ++j) {
      for (const Column& c : columns_) {
        const std::size_t at = j * size() + c.first + (c.per_joint ? j : 0);
        if (c.term.basis != nullptr) {
          entries_.push_back({at, c.term.basis, j});
        } else {
          ones_.push_back(at);
        }
      }
    }
  }
  std::vector<Column> columns_;
  std::vector<Entry> entries_;
  std::vector<std::size_t> ones_;
};

// The paper's regressor (its eq. 1.2), in this project's conventions:
//   tau_i = beta1 qdd_i + beta5 cos(q_i)
//           + l_i,x (-x sin q_i) + l_i,y (-y sin q_i) + l_i,z (z cos q_i) + l_i,0 sin q_i
// with (x, y, z) = FK(q). The lambda coefficients are free constants per arm.
class Paper14Model final : public Model {
 public:
  explicit Paper14Model(ModelOptions o) : Model(std::move(o)) {
    parameters_.push_back({"beta1", "kg m^2", true, "shared coefficient of qdd_i"});
    parameters_.push_back({"beta5", "N m", false, "shared coefficient of cos(q_i)"});
    for (int i = 1; i <= 3; ++i) {
      const std::string a = "lambda" + std::to_string(i);
      parameters_.push_back({a + "_x", "N/m", false, "coefficient of -x sin(q_i)"});
      parameters_.push_back({a + "_y", "N/m", false, "coefficient of -y sin(q_i)"});
      parameters_.push_back({a + "_z", "N/m", false, "coefficient of z cos(q_i)"});
      parameters_.push_back({a + "_0", "N m", false, "coefficient of sin(q_i)"});
    }
  }

  delta::KinematicsStatus rows(const delta::Geometry& g, double /*gravity_m_s2*/,
                               const delta::JointState& s, double* out) const override {
    const auto fk = delta::forward_kinematics(g, s.q_rad);
    if (fk.status != delta::KinematicsStatus::kOk) return fk.status;
    const auto& p = fk.position_m;
    for (unsigned j = 0; j < 3; ++j) {
      double* row = out + j * 14;
      for (std::size_t c = 0; c < 14; ++c) row[c] = 0.0;
      const double sq = std::sin(s.q_rad[j]);
      const double cq = std::cos(s.q_rad[j]);
      row[0] = s.qdd_rad_s2[j];
      row[1] = cq;
      row[2 + 4 * j] = -p.x * sq;
      row[3 + 4 * j] = -p.y * sq;
      row[4 + 4 * j] = p.z * cq;
      row[5 + 4 * j] = sq;
    }
    return delta::KinematicsStatus::kOk;
  }

  std::vector<double> parameter_vector(const delta::HighFidelityParameters&) const override {
    throw delta::InputError(
        "the paper14 model's coefficients lump constant lambdas: they have no physical truth");
  }
};

}  // namespace

std::unique_ptr<Model> make_model(const ModelOptions& options) {
  if (!(options.coulomb_smoothing_rad_s > 0.0) || !std::isfinite(options.coulomb_smoothing_rad_s)) {
    throw delta::InputError("--coulomb-smoothing must be a positive speed in rad/s");
  }
  if (!(options.stribeck_velocity_rad_s >= 0.0) ||
      !std::isfinite(options.stribeck_velocity_rad_s)) {
    throw delta::InputError("--stribeck-velocity must be a speed in rad/s, 0 for no Stribeck term");
  }
  if (options.name == "delta" || options.name == "lumped") {
    return std::make_unique<PhysicalModel>(options);
  }
  if (options.name == "paper14") {
    if (options.per_joint) {
      throw delta::InputError("--per-joint applies to --model delta and lumped only");
    }
    if (options.offsets) {
      throw delta::InputError("--offsets applies to --model delta and lumped only");
    }
    if (options.stribeck_velocity_rad_s > 0.0) {
      throw delta::InputError("--stribeck-velocity applies to --model delta and lumped only");
    }
    return std::make_unique<Paper14Model>(options);
  }
  throw delta::InputError("--model must be 'delta', 'lumped' or 'paper14', got '" + options.name +
                          "'");
}

std::vector<double> parameter_vector(const ModelOptions& options,
                                     const delta::LumpedParameters& p) {
  return make_model(options)->parameter_vector(delta::to_high_fidelity(p));
}

}  // namespace host_id
