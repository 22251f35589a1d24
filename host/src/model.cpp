#include "host_id/model.hpp"

#include <cmath>

#include "delta/input_error.hpp"

namespace host_id {

namespace {

const char* kJointSuffix[3] = {"_1", "_2", "_3"};

class DeltaModel final : public Model {
 public:
  explicit DeltaModel(ModelOptions o) : Model(std::move(o)) {
    if (options_.per_joint) {
      for (const char* s : kJointSuffix) {
        parameters_.push_back({std::string("arm_inertia") + s, "kg m^2", true,
                               "arm inertia about the motor axis, at the joint"});
      }
      for (const char* s : kJointSuffix) {
        parameters_.push_back({std::string("arm_gravity_moment") + s, "N m", true,
                               "gravity moment of the arm at theta = 0"});
      }
    } else {
      parameters_.push_back({"arm_inertia", "kg m^2", true,
                             "arm inertia about the motor axis, at the joint (all arms)"});
      parameters_.push_back(
          {"arm_gravity_moment", "N m", true, "gravity moment of an arm at theta = 0 (all arms)"});
    }
    parameters_.push_back({"platform_mass", "kg", true,
                           "equivalent platform mass: platform, payload, forearm share"});
    for (const char* s : kJointSuffix) {
      parameters_.push_back({std::string("viscous_friction") + s, "N m s/rad", true,
                             "viscous friction at the joint"});
    }
    for (const char* s : kJointSuffix) {
      parameters_.push_back(
          {std::string("coulomb_friction") + s, "N m", true, "Coulomb friction at the joint"});
    }
    if (options_.offsets) {
      for (const char* s : kJointSuffix) {
        parameters_.push_back({std::string("torque_offset") + s, "N m", false,
                               "constant torque offset of the joint's measurement"});
      }
    }
  }

  delta::KinematicsStatus rows(const delta::Geometry& g, double gravity_m_s2,
                               const delta::JointState& s, double* out) const override {
    delta::DynamicsBasis b;
    const auto status =
        delta::dynamics_basis(g, s, gravity_m_s2, options_.coulomb_smoothing_rad_s, b);
    if (status != delta::KinematicsStatus::kOk) return status;
    const std::size_t p = size();
    for (unsigned j = 0; j < 3; ++j) {
      double* row = out + j * p;
      for (std::size_t c = 0; c < p; ++c) row[c] = 0.0;
      std::size_t c = 0;
      if (options_.per_joint) {
        row[j] = b.inertia[j];
        row[3 + j] = b.gravity[j];
        c = 6;
      } else {
        row[0] = b.inertia[j];
        row[1] = b.gravity[j];
        c = 2;
      }
      row[c] = b.platform[j];
      row[c + 1 + j] = b.viscous[j];
      row[c + 4 + j] = b.coulomb[j];
      if (options_.offsets) row[c + 7 + j] = 1.0;
    }
    return delta::KinematicsStatus::kOk;
  }
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
};

}  // namespace

std::unique_ptr<Model> make_model(const ModelOptions& options) {
  if (!(options.coulomb_smoothing_rad_s > 0.0)) {
    throw delta::InputError("--coulomb-smoothing must be a positive speed in rad/s");
  }
  if (options.name == "delta") return std::make_unique<DeltaModel>(options);
  if (options.name == "paper14") {
    if (options.per_joint) throw delta::InputError("--per-joint applies to --model delta only");
    if (options.offsets) throw delta::InputError("--offsets applies to --model delta only");
    return std::make_unique<Paper14Model>(options);
  }
  throw delta::InputError("--model must be 'delta' or 'paper14', got '" + options.name + "'");
}

std::vector<double> delta_parameter_vector(const ModelOptions& options,
                                           const delta::LumpedParameters& p) {
  std::vector<double> v;
  if (options.per_joint) {
    v.insert(v.end(), p.arm_inertia_kg_m2.begin(), p.arm_inertia_kg_m2.end());
    v.insert(v.end(), p.arm_gravity_moment_Nm.begin(), p.arm_gravity_moment_Nm.end());
  } else {
    v.push_back(p.arm_inertia_kg_m2[0]);
    v.push_back(p.arm_gravity_moment_Nm[0]);
  }
  v.push_back(p.platform_mass_kg);
  v.insert(v.end(), p.viscous_friction_Nm_s_per_rad.begin(), p.viscous_friction_Nm_s_per_rad.end());
  v.insert(v.end(), p.coulomb_friction_Nm.begin(), p.coulomb_friction_Nm.end());
  if (options.offsets) v.insert(v.end(), p.torque_offset_Nm.begin(), p.torque_offset_Nm.end());
  return v;
}

}  // namespace host_id
