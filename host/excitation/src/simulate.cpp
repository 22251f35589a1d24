#include "host_id/simulate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "delta/atomic_file.hpp"
#include "delta/drive_train_plant.hpp"
#include "delta/input_error.hpp"
#include "delta/mujoco_plant.hpp"
#include "delta/path_follower.hpp"
#include "delta/splitmix.hpp"
#include "delta/trajectory.hpp"

namespace host_id {

namespace {

void check_options(const SimulateOptions& o) {
  delta::require_valid_geometry(o.geometry);
  if (!(o.duration_s > 0.0) || !(o.duration_s <= 3600.0)) {
    throw delta::InputError("--duration must be between 0 and 3600 s");
  }
  if (!(o.sample_rate_hz >= 1.0) || !(o.sample_rate_hz <= 100000.0)) {
    throw delta::InputError("--rate must be between 1 and 100000 Hz");
  }
  if (!(o.torque_noise >= 0.0) || !(o.torque_noise < 1.0)) {
    throw delta::InputError("--torque-noise is a fraction of the RMS torque, between 0 and 1");
  }
  if (o.encoder_bits > 32) throw delta::InputError("--encoder-bits must be between 0 (off) and 32");
  if (o.arm_encoders && o.plant != SimulatedPlant::kMujoco) {
    throw delta::InputError("--arm-encoders goes with --plant mujoco: the lumped plant is rigid");
  }
}

// The joint states of the chosen path at time t.
class Path {
 public:
  explicit Path(const SimulateOptions& o) : fourier_(o.trajectory == "fourier") {
    if (o.trajectory == "file") {
      if (!o.trajectory_file) throw delta::InputError("trajectory 'file' without its trajectory");
      file_ = o.trajectory_file;
    } else if (fourier_) {
      if (o.harmonics == 0 || o.harmonics > 20)
        throw delta::InputError("--harmonics must be between 1 and 20");
      if (!(o.base_frequency_hz > 0.0) || !(o.base_frequency_hz <= 5.0)) {
        throw delta::InputError("--base-hz must be between 0 and 5 Hz");
      }
      const delta::Vec3<double> centre{0.0, 0.0, -0.42};
      if (!delta::make_fourier_excitation(o.geometry, centre, o.harmonics, o.base_frequency_hz,
                                          o.amplitude_rad, o.seed, fourier_path_)) {
        throw delta::InputError(
            "no Fourier excitation fits this geometry's workspace around (0, 0, -0.42) m");
      }
    } else if (o.trajectory == "pick-and-place") {
      if (!(o.segment_duration_s >= 0.1) || !(o.segment_duration_s <= 10.0)) {
        throw delta::InputError("--segment-s must be between 0.1 and 10 s");
      }
      pnp_ = delta::default_pick_and_place(o.geometry);
      pnp_.segment_duration_s = o.segment_duration_s;
    } else {
      throw delta::InputError("--trajectory must be 'fourier' or 'pick-and-place', got '" +
                              o.trajectory + "'");
    }
  }
  delta::JointState at(double t) const {
    if (file_) return file_->at(t);
    if (fourier_) return fourier_path_.at(t);
    delta::JointState s;
    if (pnp_.at(t, s) != delta::KinematicsStatus::kOk) {
      throw delta::InputError("the pick-and-place path leaves the workspace of this geometry");
    }
    return s;
  }

 private:
  bool fourier_;
  std::optional<delta::BlendedFourierTrajectory> file_;
  delta::FourierTrajectory fourier_path_;
  delta::PickAndPlaceTrajectory pnp_;
};

// A log with the options' metadata and room for its samples.
DeltaLog empty_log(const SimulateOptions& o, std::size_t n) {
  DeltaLog log;
  log.name = "simulate";
  log.geometry = o.geometry;
  log.gravity_m_s2 = o.parameters.gravity_m_s2;
  log.sample_rate_hz = o.sample_rate_hz;
  log.metadata.emplace_back("source", "sim");
  const bool mujoco = o.plant == SimulatedPlant::kMujoco;
  log.metadata.emplace_back("robot", mujoco ? o.robot.name : "default-delta");
  log.metadata.emplace_back("plant", mujoco ? "mujoco" : "lumped");
  log.metadata.emplace_back("trajectory", o.name.empty() ? o.trajectory : o.name);
  log.has_qd = log.has_qdd = o.with_derivatives;
  for (unsigned j = 0; j < 3; ++j) {
    log.q[j].reserve(n);
    log.tau[j].reserve(n);
    if (o.arm_encoders) log.extra_columns.emplace_back("qa" + std::to_string(j + 1), Series{});
  }
  return log;
}

void append_sample(DeltaLog& log, std::size_t k, double t, const delta::JointState& s,
                   const delta::Joint3& tau) {
  log.t.push_back(t);
  log.seq.push_back(k);
  for (unsigned j = 0; j < 3; ++j) {
    log.q[j].push_back(s.q_rad[j]);
    log.tau[j].push_back(tau[j]);
    if (log.has_qd) {
      log.qd[j].push_back(s.qd_rad_s[j]);
      log.qdd[j].push_back(s.qdd_rad_s2[j]);
    }
  }
}

std::size_t sample_count(const SimulateOptions& o) {
  return static_cast<std::size_t>(std::floor(o.duration_s * o.sample_rate_hz)) + 1;
}

[[noreturn]] void no_kinematics_at(double t) {
  std::ostringstream m;
  m << "the trajectory reaches a pose without kinematics at t = " << t << " s";
  throw delta::InputError(m.str());
}

// Sample k of n done: the caller's progress every 1 % and at the end.
void report_progress(const SimulateOptions& o, std::size_t k, std::size_t n) {
  if (o.progress && ((k + 1) % std::max<std::size_t>(1, n / 100) == 0 || k + 1 == n)) {
    o.progress(k + 1, n);
  }
}

// The lumped plant: the path sampled, the torques by inverse dynamics.
DeltaLog exact_log(const SimulateOptions& o, const Path& path) {
  const std::size_t n = sample_count(o);
  DeltaLog log = empty_log(o, n);
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) / o.sample_rate_hz;
    const delta::JointState s = path.at(t);
    delta::Joint3 tau{};
    if (delta::inverse_dynamics(o.geometry, o.parameters, s, tau) != delta::KinematicsStatus::kOk) {
      no_kinematics_at(t);
    }
    append_sample(log, k, t, s, tau);
    report_progress(o, k, n);
  }
  return log;
}

// The path follower's tracking error per joint (the path's angle less the
// encoder's, or the arm's), as the controller's `tracking` line and the
// emulator's `arm tracking` line count it.
struct TrackingSums {
  delta::Joint3 sum_sq{};
  delta::Joint3 max_abs{};
  std::size_t n{0};
  void add(const delta::Joint3& reference, const delta::Joint3& q) {
    for (unsigned j = 0; j < 3; ++j) {
      const double e = reference[j] - q[j];
      sum_sq[j] += e * e;
      max_abs[j] = std::max(max_abs[j], std::abs(e));
    }
    ++n;
  }
  // Into the log's metadata as PREFIXrms_rad_1..3 and PREFIXmax_rad_1..3.
  void write(DeltaLog& log, const std::string& prefix) const {
    for (unsigned j = 0; j < 3; ++j) {
      log.metadata.emplace_back(prefix + "rms_rad_" + std::to_string(j + 1),
                                format_number(std::sqrt(sum_sq[j] / static_cast<double>(n))));
    }
    for (unsigned j = 0; j < 3; ++j) {
      log.metadata.emplace_back(prefix + "max_rad_" + std::to_string(j + 1),
                                format_number(max_abs[j]));
    }
  }
};

// The multibody plant follows the path under the PD controller with its
// lumped model as feed-forward: each sample has the state the plant is in
// and the torque applied from it to the next sample (and, with
// derivatives, the plant's own velocity and its acceleration under that
// torque).
DeltaLog followed_log(const SimulateOptions& o, const Path& path) {
  const std::size_t n = sample_count(o);
  DeltaLog log = empty_log(o, n);
  const double dt = 1.0 / o.sample_rate_hz;
  delta::MultibodyRobot plant(o.robot, path.at(0.0).q_rad, delta::MujocoSettings{});
  plant.place(path.at(0.0));
  const delta::PathFollower follower(o.robot.geometry, delta::lumped_truth(o.robot));
  // What each drive reports: the torque it commands (the nominal constant
  // times its current), through its current filter.
  std::array<delta::CurrentFilter, 3> reported;
  for (unsigned j = 0; j < 3; ++j) {
    reported[j] = delta::CurrentFilter(o.robot.joints[j].current_filter_time_constant_s);
  }
  // Behind an elastic gearbox the motor's own inertia is small: the drive
  // closes its loop faster than the log's rate, as real drives do, or the
  // follower's damping would make the light motor side unstable.
  const int loop_steps = plant.drive_train() != nullptr && plant.drive_train()->elastic()
                             ? std::max(1, static_cast<int>(std::ceil(dt / 2.5e-4)))
                             : 1;
  const double h = dt / loop_steps;
  TrackingSums motor_tracking, arm_tracking;
  for (std::size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    delta::JointState s = plant.state();
    const delta::JointState arm = plant.arm_state();
    motor_tracking.add(path.at(t).q_rad, s.q_rad);
    arm_tracking.add(path.at(t).q_rad, arm.q_rad);
    delta::Joint3 logged{};
    for (int i = 0; i < loop_steps; ++i) {
      delta::Joint3 tau{};
      if (follower.torque(path.at(t + i * h), plant.state(), tau) != delta::KinematicsStatus::kOk) {
        no_kinematics_at(t + i * h);
      }
      if (plant.step(tau, h) != delta::PlantStatus::kOk) throw delta::InputError(plant.fault());
      if (i == 0) s.qdd_rad_s2 = plant.state().qdd_rad_s2;
      for (unsigned j = 0; j < 3; ++j) logged[j] = reported[j].update(tau[j], h);
    }
    append_sample(log, k, t, s, logged);
    if (o.arm_encoders) {
      for (unsigned j = 0; j < 3; ++j) log.extra_columns[j].second.push_back(arm.q_rad[j]);
    }
    report_progress(o, k, n);
  }
  motor_tracking.write(log, "tracking_");
  if (o.arm_encoders) arm_tracking.write(log, "arm_tracking_");
  return log;
}

// Torque noise, then encoder quantisation, as a real log has them.
void add_measurement_effects(const SimulateOptions& o, DeltaLog& log) {
  // SplitMix64's normals: the same noise for a seed everywhere.
  delta::SplitMix64 noise(o.seed ^ 0x5DEECE66Dull);
  if (o.torque_noise > 0.0) {
    for (unsigned j = 0; j < 3; ++j) {
      double ss = 0.0;
      for (double v : log.tau[j]) ss += v * v;
      const double sigma = o.torque_noise * std::sqrt(ss / static_cast<double>(log.size()));
      for (double& v : log.tau[j]) v += sigma * noise.normal();
    }
    log.metadata.emplace_back("torque_noise_fraction", format_number(o.torque_noise));
  }
  if (o.encoder_bits > 0) {
    const double step = 2.0 * std::numbers::pi / std::ldexp(1.0, static_cast<int>(o.encoder_bits));
    for (unsigned j = 0; j < 3; ++j) {
      for (double& v : log.q[j]) v = std::round(v / step) * step;
    }
    for (auto& column : log.extra_columns) {
      for (double& v : column.second) v = std::round(v / step) * step;
    }
    log.metadata.emplace_back("encoder_bits", std::to_string(o.encoder_bits));
  }
}

}  // namespace

// The options as the simulation runs them: a multibody plant's geometry
// and gravity are its robot's.
SimulateOptions as_run(const SimulateOptions& options) {
  SimulateOptions o = options;
  if (o.plant == SimulatedPlant::kMujoco) {
    o.geometry = o.robot.geometry;
    o.parameters.gravity_m_s2 = o.robot.gravity_m_s2;
  }
  check_options(o);
  return o;
}

std::function<delta::JointState(double)> simulated_path(const SimulateOptions& options) {
  const auto path = std::make_shared<const Path>(as_run(options));
  return [path](double t) { return path->at(t); };
}

DeltaLog simulate_log(const SimulateOptions& options) {
  const SimulateOptions o = as_run(options);
  const Path path(o);
  DeltaLog log = o.plant == SimulatedPlant::kMujoco ? followed_log(o, path) : exact_log(o, path);
  add_measurement_effects(o, log);
  return log;
}

}  // namespace host_id
