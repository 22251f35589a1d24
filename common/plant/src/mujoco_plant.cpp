#include "delta/mujoco_plant.hpp"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"
#include "mujoco_model.hpp"

namespace delta {

namespace {

// MuJoCo's default handlers print to stdout, write MUJOCO_LOG.TXT into the
// working folder and, for errors, exit. Ours: warnings are counted in
// mjData (the plant checks them), errors become exceptions.
void ignore_warning(const char*) {}
[[noreturn]] void throw_error(const char* message) {
  throw std::runtime_error(std::string("MuJoCo: ") + message);
}

void install_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_warning = ignore_warning;
    mju_user_error = throw_error;
  });
}

mjModel* load_model(const std::string& xml) {
  install_handlers();
  auto vfs = std::make_unique<mjVFS>();  // about 2 MB: not on the stack
  mj_defaultVFS(vfs.get());
  const char* name = "delta.xml";
  if (mj_makeEmptyFileVFS(vfs.get(), name, static_cast<int>(xml.size())) != 0) {
    throw std::runtime_error("MuJoCo: cannot make the model's in-memory file");
  }
  std::memcpy(vfs->filedata[mj_findFileVFS(vfs.get(), name)], xml.data(), xml.size());
  char error[1000] = "";
  mjModel* m = mj_loadXML(name, vfs.get(), error, sizeof error);
  mj_deleteVFS(vfs.get());
  if (!m) throw InputError(std::string("the robot gives no MuJoCo model: ") + error);
  return m;
}

int joint_id(const mjModel* m, const std::string& name) {
  const int id = mj_name2id(m, mjOBJ_JOINT, name.c_str());
  if (id < 0) throw std::logic_error("MuJoCo model without joint " + name);
  return id;
}

Vec3<double> body_point(const mjData* d, int body, const Vec3<double>& local) {
  const mjtNum* p = d->xpos + 3 * body;
  const mjtNum* r = d->xmat + 9 * body;
  return {p[0] + r[0] * local.x + r[1] * local.y + r[2] * local.z,
          p[1] + r[3] * local.x + r[4] * local.y + r[5] * local.z,
          p[2] + r[6] * local.x + r[7] * local.y + r[8] * local.z};
}

// The world-to-body expression of a world vector (xmat is row-major,
// body-to-world).
Vec3<double> to_body(const mjData* d, int body, const Vec3<double>& v) {
  const mjtNum* r = d->xmat + 9 * body;
  return {r[0] * v.x + r[3] * v.y + r[6] * v.z, r[1] * v.x + r[4] * v.y + r[7] * v.z,
          r[2] * v.x + r[5] * v.y + r[8] * v.z};
}

}  // namespace

MujocoPlant::MujocoPlant(const RobotDescription& d, const Joint3& q0_rad, MujocoSettings settings)
    : robot_(d), settings_(settings) {
  validate_robot_description(d, "robot description");
  if (!(settings.max_step_s > 0.0)) throw InputError("the plant's step must be positive");
  model_ = load_model(mujoco_model_xml(d, settings));
  data_ = mj_makeData(model_);
  scratch_ = mj_makeData(model_);
  for (int c = 0; c < 3; ++c) {
    const std::string n = std::to_string(c + 1);
    const int hinge = joint_id(model_, "theta" + n);
    hinge_qpos_[c] = model_->jnt_qposadr[hinge];
    hinge_dof_[c] = model_->jnt_dofadr[hinge];
    ball_qpos_[2 * c] = model_->jnt_qposadr[joint_id(model_, "ball" + n + "a")];
    ball_qpos_[2 * c + 1] = model_->jnt_qposadr[joint_id(model_, "ball" + n + "b")];
    rod_body_[2 * c] = mj_name2id(model_, mjOBJ_BODY, ("rod" + n + "a").c_str());
    rod_body_[2 * c + 1] = mj_name2id(model_, mjOBJ_BODY, ("rod" + n + "b").c_str());
  }
  free_qpos_ = model_->jnt_qposadr[joint_id(model_, "platform")];
  platform_body_ = mj_name2id(model_, mjOBJ_BODY, "platform");
  rod_home_ = rod_home_direction(d);
  // Where each rod's end sits on the platform, in the platform's frame.
  mju_copy(scratch_->qpos, model_->qpos0, model_->nq);
  mj_kinematics(model_, scratch_);
  const Vec3<double> end{d.geometry.forearm_length_m, 0.0, 0.0};
  for (int k = 0; k < 6; ++k) {
    const Vec3<double> world = body_point(scratch_, rod_body_[k], end);
    const mjtNum* p = scratch_->xpos + 3 * platform_body_;
    platform_anchor_[static_cast<unsigned>(k)] =
        to_body(scratch_, platform_body_, world - Vec3<double>{p[0], p[1], p[2]});
  }
  place(JointState{q0_rad, {}, {}});
}

MujocoPlant::~MujocoPlant() {
  mj_deleteData(scratch_);
  mj_deleteData(data_);
  mj_deleteModel(model_);
}

bool MujocoPlant::assemble(const Joint3& q, double* qpos) const {
  const Geometry& g = robot_.geometry;
  const auto fk = forward_kinematics(g, q);
  if (fk.status != KinematicsStatus::kOk) return false;
  mju_copy(qpos, model_->qpos0, model_->nq);
  const Vec3<double> p = fk.position_m;
  // The rod's home direction is the x axis of its body frame; y is the
  // motor axis, z = x cross y.
  const Vec3<double> x0 = rod_home_;
  const Vec3<double> y0{0.0, 1.0, 0.0};
  const Vec3<double> z0 = x0.cross(y0);
  for (int c = 0; c < 3; ++c) {
    const auto uc = static_cast<unsigned>(c);
    const Vec3<double> u{kChainCos[uc], kChainSin[uc], 0.0};
    const Vec3<double> t{-kChainSin[uc], kChainCos[uc], 0.0};
    const Vec3<double> z{0.0, 0.0, 1.0};
    const double th = q[uc];
    qpos[hinge_qpos_[c]] = th;
    const Vec3<double> ex = u * std::cos(th) - z * std::sin(th);
    const Vec3<double> ez = z * std::cos(th) + u * std::sin(th);
    const Vec3<double> dir =
        (p + u * g.platform_radius_m - elbow_position(g, c, th)) * (1.0 / g.forearm_length_m);
    const Vec3<double> in_arm{dir.dot(ex), dir.dot(t), dir.dot(ez)};
    // The rod's direction in its own home frame, v; the ball joint turns
    // x onto v by the shortest rotation: quaternion (1 + v.x, x cross v).
    const Vec3<double> v{x0.dot(in_arm), y0.dot(in_arm), z0.dot(in_arm)};
    double quat[4] = {1.0 + v.x, 0.0, -v.z, v.y};
    mju_normalize4(quat);
    for (int side = 0; side < 2; ++side) mju_copy4(qpos + ball_qpos_[2 * c + side], quat);
  }
  qpos[free_qpos_ + 0] = p.x;
  qpos[free_qpos_ + 1] = p.y;
  qpos[free_qpos_ + 2] = p.z;
  const double identity[4] = {1.0, 0.0, 0.0, 0.0};
  mju_copy4(qpos + free_qpos_ + 3, identity);
  return true;
}

void MujocoPlant::tree_motion(const JointState& s, double* qvel, double* qacc) {
  const int nq = model_->nq, nv = model_->nv;
  std::vector<double> before(static_cast<std::size_t>(nq)), now(before), after(before);
  std::vector<double> back(static_cast<std::size_t>(nv)), ahead(back);
  const double h = 1e-4;
  const auto at = [&](double sigma, double* qpos) {
    Joint3 q{};
    for (unsigned j = 0; j < 3; ++j)
      q[j] = s.q_rad[j] + s.qd_rad_s[j] * sigma + 0.5 * s.qdd_rad_s2[j] * sigma * sigma;
    if (!assemble(q, qpos)) throw InputError("the joint state has no forward kinematics");
  };
  at(-h, before.data());
  at(0.0, now.data());
  at(h, after.data());
  mj_differentiatePos(model_, back.data(), h, before.data(), now.data());
  mj_differentiatePos(model_, ahead.data(), h, now.data(), after.data());
  for (int k = 0; k < nv; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    qvel[k] = 0.5 * (back[uk] + ahead[uk]);
    qacc[k] = (ahead[uk] - back[uk]) / h;
  }
}

void MujocoPlant::place(const JointState& s) {
  if (!assemble(s.q_rad, data_->qpos)) {
    throw InputError("the plant cannot be placed at joint angles without forward kinematics");
  }
  tree_motion(s, data_->qvel, data_->qacc);
  mju_zero(data_->qacc_warmstart, model_->nv);
  mju_zero(data_->qfrc_applied, model_->nv);
  last_qdd_ = s.qdd_rad_s2;
  fault_.clear();
}

Joint3 MujocoPlant::inverse_dynamics(const JointState& s) {
  if (!assemble(s.q_rad, scratch_->qpos)) {
    throw InputError("inverse dynamics at joint angles without forward kinematics");
  }
  tree_motion(s, scratch_->qvel, scratch_->qacc);
  mju_zero(scratch_->qfrc_applied, model_->nv);
  // The open tree (constraints off): f = M qacc + bias.
  const int flags = model_->opt.disableflags;
  model_->opt.disableflags = flags | mjDSBL_CONSTRAINT;
  mj_inverse(model_, scratch_);
  model_->opt.disableflags = flags;
  const std::vector<double> f(scratch_->qfrc_inverse, scratch_->qfrc_inverse + model_->nv);
  // G's column j: the tree's velocity per unit joint velocity j.
  const int nq = model_->nq, nv = model_->nv;
  std::vector<double> plus(static_cast<std::size_t>(nq)), minus(plus);
  std::vector<double> column(static_cast<std::size_t>(nv));
  const double h = 1e-6;
  Joint3 tau{};
  for (unsigned j = 0; j < 3; ++j) {
    Joint3 qp = s.q_rad, qm = s.q_rad;
    qp[j] += h;
    qm[j] -= h;
    if (!assemble(qp, plus.data()) || !assemble(qm, minus.data())) {
      throw InputError("inverse dynamics too close to a pose without forward kinematics");
    }
    mj_differentiatePos(model_, column.data(), 2.0 * h, minus.data(), plus.data());
    tau[j] =
        mju_dot(column.data(), f.data(), nv) + joint_friction_Nm(robot_.joints[j], s.qd_rad_s[j]);
  }
  return tau;
}

double MujocoPlant::constraint_violation_m() {
  mju_copy(scratch_->qpos, data_->qpos, model_->nq);
  mj_kinematics(model_, scratch_);
  const Vec3<double> end{robot_.geometry.forearm_length_m, 0.0, 0.0};
  double worst = 0.0;
  for (int k = 0; k < 6; ++k) {
    const Vec3<double> rod_end = body_point(scratch_, rod_body_[k], end);
    const Vec3<double> joint =
        body_point(scratch_, platform_body_, platform_anchor_[static_cast<unsigned>(k)]);
    worst = std::max(worst, std::sqrt((rod_end - joint).squared_norm()));
  }
  return worst;
}

void MujocoPlant::set_fault(const std::string& why) {
  std::ostringstream m;
  m << "the plant faulted at " << time_s_ << " s: " << why;
  fault_ = m.str();
  mju_zero(data_->qvel, model_->nv);
}

PlantStatus MujocoPlant::step(const Joint3& tau_Nm, double dt_s) {
  if (!fault_.empty()) return PlantStatus::kDiverged;
  const int n = std::max(1, static_cast<int>(std::ceil(dt_s / settings_.max_step_s - 1e-9)));
  model_->opt.timestep = dt_s / n;
  for (unsigned k = 0; k < 3; ++k) {
    data_->xfrc_applied[6 * platform_body_ + static_cast<int>(k)] = platform_force_N_[k];
  }
  for (int i = 0; i < n; ++i) {
    for (unsigned j = 0; j < 3; ++j) {
      const int dof = hinge_dof_[j];
      data_->qfrc_applied[dof] = tau_Nm[j] - joint_friction_Nm(robot_.joints[j], data_->qvel[dof]);
    }
    const int bad_before = data_->warning[mjWARN_BADQACC].number;
    mj_step(model_, data_);
    if (i == 0) {
      for (unsigned j = 0; j < 3; ++j) last_qdd_[j] = data_->qacc[hinge_dof_[j]];
    }
    time_s_ += model_->opt.timestep;
    if (data_->warning[mjWARN_BADQACC].number != bad_before) {
      set_fault("MuJoCo found its accelerations not finite (the simulation diverged)");
      return PlantStatus::kDiverged;
    }
  }
  const std::string wrong = check_plant_state(state());
  if (!wrong.empty()) {
    set_fault(wrong);
    return PlantStatus::kDiverged;
  }
  const double violation = constraint_violation_m();
  max_violation_m_ = std::max(max_violation_m_, violation);
  if (violation > kMaxViolation_m) {
    std::ostringstream m;
    m << "the closed chains came apart (a rod end " << violation * 1e3
      << " mm from its platform joint)";
    set_fault(m.str());
    return PlantStatus::kDiverged;
  }
  if (forward_kinematics(robot_.geometry, state().q_rad).status != KinematicsStatus::kOk) {
    set_fault("the robot reached a pose without forward kinematics");
    return PlantStatus::kNoKinematics;
  }
  return PlantStatus::kOk;
}

void MujocoPlant::stop() {
  mju_zero(data_->qvel, model_->nv);
  mju_zero(data_->qacc_warmstart, model_->nv);
}

JointState MujocoPlant::state() const {
  JointState s;
  for (unsigned j = 0; j < 3; ++j) {
    s.q_rad[j] = data_->qpos[hinge_qpos_[j]];
    s.qd_rad_s[j] = data_->qvel[hinge_dof_[j]];
  }
  s.qdd_rad_s2 = last_qdd_;
  return s;
}

double MujocoPlant::total_energy_J() {
  mju_copy(scratch_->qpos, data_->qpos, model_->nq);
  mju_copy(scratch_->qvel, data_->qvel, model_->nv);
  mju_zero(scratch_->qfrc_applied, model_->nv);
  // Energy is off in the model (it costs every step); on for this call.
  const int flags = model_->opt.enableflags;
  model_->opt.enableflags = flags | mjENBL_ENERGY;
  mj_forward(model_, scratch_);
  model_->opt.enableflags = flags;
  return scratch_->energy[0] + scratch_->energy[1];
}

}  // namespace delta
