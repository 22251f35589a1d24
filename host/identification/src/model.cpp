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
    add_drive_train_terms();
    plan_rows();
  }

  delta::KinematicsStatus rows(const delta::Geometry& g, double gravity_m_s2,
                               const delta::JointState& s, const delta::Joint3& tau_Nm,
                               double* out) const override {
    delta::DynamicsBasis b;
    const auto status = delta::dynamics_basis(g, s, gravity_m_s2, options_.coulomb_smoothing_rad_s,
                                              b, options_.stribeck_velocity_rad_s);
    if (status != delta::KinematicsStatus::kOk) return status;
    rows_of(b, out);
    const std::size_t p = size();
    for (unsigned j = 0; j < 3; ++j) {
      if (load_first_ != kNone) {
        out[j * p + load_first_ + j] = std::abs(tau_Nm[j]) * load_shape(s.qd_rad_s[j]);
      }
      if (gain_first_ != kNone && j > 0) out[j * p + gain_first_ + j - 1] = tau_Nm[j];
      if (cogging_first_[j] != kNone) {
        const double phase = options_.cogging_periods_per_rev[j] * s.q_rad[j];
        out[j * p + cogging_first_[j]] = std::sin(phase);
        out[j * p + cogging_first_[j] + 1] = std::cos(phase);
      }
    }
    return delta::KinematicsStatus::kOk;
  }

  std::vector<std::size_t> cogging_columns() const override {
    std::vector<std::size_t> out;
    for (const std::size_t first : cogging_first_) {
      if (first == kNone) continue;
      out.push_back(first);
      out.push_back(first + 1);
    }
    return out;
  }

  std::vector<std::size_t> torque_columns() const override {
    std::vector<std::size_t> out;
    for (std::size_t j = 0; j < 3 && load_first_ != kNone; ++j) out.push_back(load_first_ + j);
    for (std::size_t j = 0; j < 2 && gain_first_ != kNone; ++j) out.push_back(gain_first_ + j);
    return out;
  }

  // tau (1 - delta_j) - mu_j s |tau| = y, s = tanh(qd / w): tau has y's sign
  // wherever 1 - delta_j - mu_j |s| > 0, as any physical drive train has.
  double solve_torque(unsigned joint, double y_Nm, double qd_rad_s,
                      const Eigen::VectorXd& beta) const override {
    double gain = 1.0;
    if (gain_first_ != kNone && joint > 0) {
      gain -= beta(static_cast<Eigen::Index>(gain_first_ + joint - 1));
    }
    if (load_first_ != kNone) {
      const double mu = beta(static_cast<Eigen::Index>(load_first_ + joint));
      gain -= mu * load_shape(qd_rad_s) * (y_Nm < 0.0 ? -1.0 : 1.0);
    }
    return gain > kSmallestGain ? y_Nm / gain : y_Nm / kSmallestGain;
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

  // A drive train's terms are 0 in the rigid, ideal robot that h describes.
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
    v.resize(size(), 0.0);
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
  // The drive train's columns, after the basis's: load friction per joint,
  // then joints 2 and 3's torque gains, then each joint's cogging.
  void add_drive_train_terms() {
    if (options_.load_friction) {
      load_first_ = parameters_.size();
      for (int j = 1; j <= 3; ++j) {
        parameters_.push_back(
            {"load_friction_" + std::to_string(j), "-", true,
             "gear friction per N m of torque the gear carries: mu |tau| tanh(qd/w), joint " +
                 std::to_string(j)});
      }
    }
    if (options_.torque_gains) {
      gain_first_ = parameters_.size();
      for (int j = 2; j <= 3; ++j) {
        parameters_.push_back({"torque_gain_gap_" + std::to_string(j), "-", false,
                               "1 - joint " + std::to_string(j) +
                                   "'s torque constant over joint 1's (delta tau in its row)"});
      }
    }
    for (unsigned j = 0; j < 3; ++j) {
      if (options_.cogging_periods_per_rev[j] == 0.0) continue;
      cogging_first_[j] = parameters_.size();
      const std::string joint = std::to_string(j + 1);
      for (const char* part : {"sin", "cos"}) {
        parameters_.push_back({std::string("cogging_") + part + "_" + joint, "N m", false,
                               std::string("cogging: coefficient of ") + part +
                                   "(n q), n its periods per revolution, joint " + joint});
      }
    }
  }
  double load_shape(double qd_rad_s) const {
    return std::tanh(qd_rad_s / options_.coulomb_smoothing_rad_s);
  }
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  // Below this, a drive train's gain (1 - delta - mu) is not physical: the
  // solved torque is held finite.
  static constexpr double kSmallestGain = 0.05;
  std::vector<Column> columns_;
  std::vector<Entry> entries_;
  std::vector<std::size_t> ones_;
  std::size_t load_first_{kNone}, gain_first_{kNone};
  std::array<std::size_t, 3> cogging_first_{kNone, kNone, kNone};
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
                               const delta::JointState& s, const delta::Joint3& /*tau_Nm*/,
                               double* out) const override {
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
  for (const double n : options.cogging_periods_per_rev) {
    if (!(n >= 0.0 && n <= kMaxCoggingPeriodsPerRev)) {
      throw delta::InputError(
          "--cogging-periods: each joint's periods per revolution must be 0 (none) to " +
          std::to_string(static_cast<int>(kMaxCoggingPeriodsPerRev)) + ", got " +
          std::to_string(n));
    }
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
    if (options.load_friction || options.torque_gains) {
      throw delta::InputError(
          "--load-friction and --torque-gains apply to --model delta and lumped only");
    }
    if (options.cogging()) {
      throw delta::InputError("--cogging-periods applies to --model delta and lumped only");
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
