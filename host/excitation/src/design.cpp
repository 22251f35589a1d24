#include "host_id/design.hpp"

#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <numbers>

#include "delta/input_error.hpp"
#include "delta/kinematics.hpp"

namespace host_id {

namespace {

// What sampling a trajectory found: the regressor's information matrix
// (sum of row^T row) and how far the samples break the limits.
struct Evaluation {
  Eigen::MatrixXd gram;
  double violation{0};  // sum of the relative excesses; 0: every sample inside
  std::string first_violation;
  double largest_torque_Nm{0};
  std::array<double, 3> payload_sq{};  // per joint: the sum of (payload torque per kg)^2
  std::size_t samples{0};
  // Each joint's RMS payload torque per kg; the smallest.
  std::array<double, 3> payload_rms() const {
    std::array<double, 3> r{};
    for (unsigned j = 0; j < 3; ++j)
      r[j] = samples > 0 ? std::sqrt(payload_sq[j] / static_cast<double>(samples)) : 0.0;
    return r;
  }
  double weakest_payload() const {
    const auto r = payload_rms();
    return std::min({r[0], r[1], r[2]});
  }
};

class Evaluator {
 public:
  Evaluator(const DesignOptions& o, const delta::RobotDescription& robot)
      : options_(o),
        model_(make_model(o.model)),
        geometry_(robot.geometry),
        gravity_(robot.gravity_m_s2),
        nominal_(model_->parameter_vector(delta::high_fidelity_truth(robot))),
        rows_(3 * model_->size()) {
    const auto& p = model_->parameters();
    for (std::size_t c = 0; c < p.size(); ++c) {
      if (p[c].name == "platform_mass" || p[c].name == "platform_inertial_mass" ||
          p[c].name == "platform_weight_mass") {
        platform_.push_back(c);  // the columns a payload's mass adds to
      }
    }
  }

  const Model& model() const { return *model_; }
  const std::vector<double>& nominal() const { return nominal_; }

  Evaluation start() const {
    Evaluation e;
    const auto p = static_cast<Eigen::Index>(model_->size());
    e.gram = Eigen::MatrixXd::Zero(p, p);
    return e;
  }

  // The samples t0, t0 + dt, ... below t1 of a path (anything with
  // at(time)), against the limits times margin.
  template <class Path>
  void add(const Path& t, double t0, double t1, double dt, double margin, Evaluation& e) const {
    for (double time = t0; time < t1; time += dt) sample(t.at(time), time, margin, e);
  }

 private:
  void breach(Evaluation& e, double excess, const char* what, double time, int joint) const {
    e.violation += excess;
    if (!e.first_violation.empty()) return;
    char buf[160];
    if (joint >= 0) {
      std::snprintf(buf, sizeof buf, "%s at t = %.3f s, joint %d", what, time, joint + 1);
    } else {
      std::snprintf(buf, sizeof buf, "%s at t = %.3f s", what, time);
    }
    e.first_violation = buf;
  }

  void sample(const delta::JointState& s, double time, double margin, Evaluation& e) const {
    const DesignLimits& l = options_.limits;
    // The joint range shrunk about its middle by the margin (scaling the
    // ends would widen a range whose lower end is positive).
    const double middle = 0.5 * (l.min_rad + l.max_rad);
    const double half = 0.5 * (l.max_rad - l.min_rad) * margin;
    for (unsigned j = 0; j < 3; ++j) {
      const int jj = static_cast<int>(j);
      const double outside = std::abs(s.q_rad[j] - middle) - half;
      if (outside > 0.0) breach(e, outside / half, "joint range", time, jj);
      const double v = std::abs(s.qd_rad_s[j]) / (l.max_velocity_rad_s * margin);
      if (v > 1.0) breach(e, v - 1.0, "velocity limit", time, jj);
      const double a = std::abs(s.qdd_rad_s2[j]) / (l.max_acceleration_rad_s2 * margin);
      if (a > 1.0) breach(e, a - 1.0, "acceleration limit", time, jj);
    }
    const auto fk = delta::forward_kinematics(geometry_, s.q_rad);
    if (fk.status != delta::KinematicsStatus::kOk) {
      breach(e, 10.0, "outside the workspace (no forward kinematics)", time, -1);
      return;
    }
    delta::WorkspaceLimits<double> wl;
    wl.joint_min_rad = l.min_rad;
    wl.joint_max_rad = l.max_rad;
    const auto ws = delta::check_workspace(geometry_, fk.position_m, wl);
    if (ws.status != delta::WorkspaceStatus::kInside) {
      breach(e, 1.0, "outside the workspace (near a singularity or unreachable)", time, -1);
      return;
    }
    if (model_->rows(geometry_, gravity_, s, delta::Joint3{}, rows_.data()) !=
        delta::KinematicsStatus::kOk) {
      breach(e, 10.0, "a singular pose", time, -1);
      return;
    }
    const std::size_t p = model_->size();
    const Eigen::Map<const Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor>> rows(
        rows_.data(), 3, static_cast<Eigen::Index>(p));
    e.gram.noalias() += rows.transpose() * rows;
    ++e.samples;
    for (unsigned j = 0; j < 3; ++j) {
      double payload = 0.0;
      for (const std::size_t c : platform_) payload += rows_[j * p + c];
      e.payload_sq[j] += payload * payload;
      double tau = 0.0;
      for (std::size_t c = 0; c < p; ++c) tau += rows_[j * p + c] * nominal_[c];
      e.largest_torque_Nm = std::max(e.largest_torque_Nm, std::abs(tau));
      const double excess = std::abs(tau) / (l.max_torque_Nm * margin);
      if (excess > 1.0) breach(e, excess - 1.0, "torque limit", time, static_cast<int>(j));
    }
  }

  DesignOptions options_;
  std::unique_ptr<Model> model_;
  delta::Geometry geometry_;
  double gravity_;
  std::vector<double> nominal_;
  std::vector<std::size_t> platform_;
  mutable std::vector<double> rows_;
};

// The condition number and log determinant of the column-scaled
// information matrix; infinite and -infinite where it is singular.
struct Conditioning {
  double condition_number{std::numeric_limits<double>::infinity()};
  double log_det{-std::numeric_limits<double>::infinity()};
};

Conditioning conditioning(const Eigen::MatrixXd& gram) {
  Conditioning c;
  const Eigen::VectorXd d = gram.diagonal().cwiseSqrt();
  if (!(d.minCoeff() > 0.0)) return c;
  const Eigen::VectorXd inv = d.cwiseInverse();
  const Eigen::MatrixXd scaled = inv.asDiagonal() * gram * inv.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(scaled, Eigen::EigenvaluesOnly);
  const Eigen::VectorXd l = eig.eigenvalues();
  if (!(l(0) > 0.0)) return c;
  c.condition_number = std::sqrt(l(l.size() - 1) / l(0));
  c.log_det = l.array().log().sum();
  return c;
}

// The whole trajectory once: the rising blend, one period (the others
// repeat it), the falling blend.
Evaluation evaluate_design(const Evaluator& ev, const delta::BlendedFourierTrajectory& t,
                           double rate_hz, double margin) {
  Evaluation e = ev.start();
  const double dt = 1.0 / rate_hz;
  const double period = 1.0 / t.fourier.base_frequency_hz;
  ev.add(t, 0.0, t.blend_s + period, dt, margin, e);
  ev.add(t, t.duration_s() - t.blend_s, t.duration_s() + 0.5 * dt, dt, margin, e);
  return e;
}

delta::BlendedFourierTrajectory trajectory_of(const Eigen::VectorXd& x, const DesignOptions& o,
                                              const delta::Joint3& q0) {
  delta::BlendedFourierTrajectory t;
  t.blend_s = o.blend_s;
  t.periods = o.periods;
  t.fourier.base_frequency_hz = o.base_frequency_hz;
  t.fourier.q0_rad = q0;
  for (unsigned j = 0; j < 3; ++j) {
    t.fourier.a_rad_s[j].resize(o.harmonics);
    t.fourier.b_rad_s[j].resize(o.harmonics);
    for (unsigned k = 0; k < o.harmonics; ++k) {
      const auto i = static_cast<Eigen::Index>(2 * (j * o.harmonics + k));
      t.fourier.a_rad_s[j][k] = x(i);
      t.fourier.b_rad_s[j][k] = x(i + 1);
    }
  }
  return t;
}

void check_options(const DesignOptions& o) {
  if (o.harmonics < 1 || o.harmonics > 6) {
    throw delta::InputError("--harmonics must be between 1 and 6 (the controller's limit)");
  }
  if (!(o.base_frequency_hz >= 0.01) || !(o.base_frequency_hz <= 2.0)) {
    throw delta::InputError("--base-hz must be between 0.01 and 2 Hz");
  }
  if (!(o.blend_s > 0.0) || !(o.blend_s <= 60.0)) {
    throw delta::InputError("--blend must be between 0 and 60 s");
  }
  if (o.periods < 1 || o.periods > 100) {
    throw delta::InputError("--periods must be between 1 and 100");
  }
  if (!(o.max_amplitude_rad > 0.0) || !(o.max_amplitude_rad <= 1.5)) {
    throw delta::InputError("--max-amplitude must be between 0 and 1.5 rad");
  }
}

}  // namespace

DesignOptions default_design_options() {
  DesignOptions o;
  o.pso.particles = 30;
  o.pso.iterations = 300;
  o.pso.stall_iterations = 60;
  o.pso.stall_tolerance = 1e-6;
  o.pso.restarts = 1;
  return o;
}

ExcitationQuality excitation_quality(const delta::BlendedFourierTrajectory& t,
                                     const DesignOptions& options,
                                     const delta::RobotDescription& robot, double check_rate_hz) {
  const Evaluator ev(options, robot);
  Evaluation e = ev.start();
  ev.add(t, 0.0, t.duration_s() + 0.5 / check_rate_hz, 1.0 / check_rate_hz, 1.0, e);
  ExcitationQuality q;
  q.feasible = e.violation == 0.0;
  q.violation = e.first_violation;
  q.largest_torque_Nm = e.largest_torque_Nm;
  q.payload_torque_rms_Nm_per_kg = e.payload_rms();
  const Conditioning c = conditioning(e.gram);
  q.condition_number_scaled = c.condition_number;
  q.log_det_scaled = c.log_det;
  q.nominal = ev.nominal();
  // A log at log_rate_hz sees log_rate / check_rate times the information.
  const Eigen::MatrixXd info = e.gram * (options.log_rate_hz / check_rate_hz);
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(info);
  const auto p = info.rows();
  q.std_dev.assign(static_cast<std::size_t>(p), std::numeric_limits<double>::infinity());
  q.rel_std_percent.assign(static_cast<std::size_t>(p), std::numeric_limits<double>::quiet_NaN());
  if (lu.isInvertible()) {
    const Eigen::MatrixXd cov = options.torque_noise_Nm * options.torque_noise_Nm * lu.inverse();
    for (Eigen::Index i = 0; i < p; ++i) {
      const auto k = static_cast<std::size_t>(i);
      q.std_dev[k] = std::sqrt(std::max(0.0, cov(i, i)));
      if (q.nominal[k] != 0.0) q.rel_std_percent[k] = 100.0 * q.std_dev[k] / std::abs(q.nominal[k]);
    }
  }
  return q;
}

DesignLimits with_robot_limits(DesignLimits base, const delta::RobotLimits& robot) {
  base.min_rad = robot.min_rad.value_or(base.min_rad);
  base.max_rad = robot.max_rad.value_or(base.max_rad);
  base.max_velocity_rad_s = robot.max_velocity_rad_s.value_or(base.max_velocity_rad_s);
  base.max_acceleration_rad_s2 =
      robot.max_acceleration_rad_s2.value_or(base.max_acceleration_rad_s2);
  base.max_torque_Nm = robot.max_torque_Nm.value_or(base.max_torque_Nm);
  return base;
}

std::string limit_violation(const std::function<delta::JointState(double)>& path, double duration_s,
                            const DesignOptions& options, const delta::RobotDescription& robot,
                            double check_rate_hz) {
  struct At {
    const std::function<delta::JointState(double)>& f;
    delta::JointState at(double t) const { return f(t); }
  };
  const Evaluator ev(options, robot);
  Evaluation e = ev.start();
  ev.add(At{path}, 0.0, duration_s + 0.5 / check_rate_hz, 1.0 / check_rate_hz, 1.0, e);
  return e.first_violation;
}

DesignResult design_excitation(const DesignOptions& options, const delta::RobotDescription& robot) {
  const auto t0 = std::chrono::steady_clock::now();
  check_options(options);
  const auto ik = delta::inverse_kinematics(robot.geometry, options.centre_m);
  if (ik.status != delta::KinematicsStatus::kOk) {
    throw delta::InputError("--centre lies outside the workspace of this robot");
  }
  const Evaluator ev(options, robot);
  const double w = 2.0 * std::numbers::pi * options.base_frequency_hz;
  // Velocity amplitudes: harmonic k's position amplitude max_amplitude / k
  // is a velocity amplitude of k w max_amplitude / k = w max_amplitude.
  const auto n = static_cast<Eigen::Index>(6 * options.harmonics);
  const Eigen::VectorXd upper = Eigen::VectorXd::Constant(n, w * options.max_amplitude_rad);
  const Eigen::VectorXd lower = -upper;
  const auto cost = [&](const Eigen::VectorXd& x) {
    const Evaluation e = evaluate_design(ev, trajectory_of(x, options, ik.theta_rad),
                                         options.evaluation_rate_hz, options.margin);
    if (e.violation > 0.0) return 1e6 * (1.0 + e.violation);
    const Conditioning c = conditioning(e.gram);
    if (!std::isfinite(c.condition_number)) return 1e6;
    switch (options.criterion) {
      case DesignCriterion::kConditionNumber:
        return c.condition_number;
      case DesignCriterion::kLogDet:
        return -c.log_det;
      case DesignCriterion::kCalibration: {
        const double weakest = e.weakest_payload();
        return weakest > 0.0 ? std::min(1e6, c.condition_number / (weakest * weakest)) : 1e6;
      }
    }
    return 1e6;
  };
  DesignResult r;
  r.pso = run_pso(cost, lower, upper, options.pso);
  r.trajectory = trajectory_of(r.pso.best, options, ik.theta_rad);
  r.quality = excitation_quality(r.trajectory, options, robot);
  if (!r.quality.feasible) {
    throw delta::InputError("no excitation within the limits was found: the best breaks the " +
                            r.quality.violation +
                            "; lower --max-amplitude or --base-hz, or raise the limits");
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

delta::BlendedFourierTrajectory preset_trajectory(const std::string& name,
                                                  const delta::RobotDescription& robot,
                                                  double blend_s) {
  const delta::FourierPreset* p = delta::fourier_preset(name.c_str());
  if (p == nullptr) throw delta::InputError("'" + name + "' is not a Fourier preset");
  delta::BlendedFourierTrajectory t;
  if (!delta::make_fourier_excitation(robot.geometry, p->centre_m, p->harmonics,
                                      p->base_frequency_hz, p->amplitude_rad, p->seed, t.fourier)) {
    throw delta::InputError(name + ": no Fourier excitation fits this robot's workspace");
  }
  t.blend_s = blend_s;
  t.periods = p->periods;
  return t;
}

}  // namespace host_id
