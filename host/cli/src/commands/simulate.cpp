// host_id simulate -o LOG.csv: a log from known parameters.
#include "host_id/simulate.hpp"

#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>

#include "commands/command.hpp"
#include "commands/progress.hpp"
#include "delta/atomic_file.hpp"
#include "delta/parameter_file.hpp"
#include "delta/robot_description.hpp"
#include "delta/trajectory_file.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/design.hpp"

namespace host_id {

namespace {

struct SimulateArguments {
  std::string out_path;
  std::string trajectory_file;
  CLI::Option* duration_given{nullptr};
  CLI::Option* trajectory_given{nullptr};
  std::string params_path;
  std::string plant{"lumped"};
  std::string robot_path;
  bool quiet{false};
  bool ignore_limits{false};
  bool json{false};
  SimulateOptions simulate;
};

void add_path_options(CLI::App& c, SimulateOptions& s) {
  c.add_option("--trajectory", s.trajectory, "the path")
      ->check(CLI::IsMember({"fourier", "pick-and-place"}))
      ->capture_default_str();
  c.add_option("--duration", s.duration_s, "seconds")
      ->check(finite_range(0.0, 3600.0) & kPositive)
      ->capture_default_str();
  c.add_option("--rate", s.sample_rate_hz, "sample rate, Hz")
      ->check(finite_range(1.0, 100000.0))
      ->capture_default_str();
  c.add_option("--seed", s.seed, "Fourier coefficients and noise")->capture_default_str();
  c.add_option("--harmonics", s.harmonics, "Fourier harmonics")
      ->check(CLI::Range(1, 20))
      ->capture_default_str();
  c.add_option("--base-hz", s.base_frequency_hz, "Fourier base frequency")
      ->check(finite_range(0.0, 5.0) & kPositive)
      ->capture_default_str();
  c.add_option("--amplitude", s.amplitude_rad, "largest joint amplitude of the Fourier path, rad")
      ->check(kPositive)
      ->capture_default_str();
  c.add_option("--segment-s", s.segment_duration_s,
               "the pick-and-place path's time per segment, s (accelerations grow as its "
               "inverse square)")
      ->check(finite_range(0.1, 10.0))
      ->capture_default_str();
}

void add_measurement_options(CLI::App& c, SimulateOptions& s) {
  c.add_option("--torque-noise", s.torque_noise,
               "Gaussian torque noise, a fraction of each joint's RMS torque")
      ->check(finite_range(0.0, 1.0, true))
      ->capture_default_str();
  c.add_option("--encoder-bits", s.encoder_bits, "quantise q to 2 pi / 2^N (0: off)")
      ->check(CLI::Range(0, 32))
      ->capture_default_str();
  c.add_flag("--with-derivatives", s.with_derivatives, "also write exact qd and qdd columns");
  c.add_flag("--arm-encoders", s.arm_encoders,
             "--plant mujoco: also write the arm side's encoders, columns qa1..qa3 (the arm's "
             "angle behind an elastic gearbox), quantised as q");
  c.add_option("--name", s.name, "the log's trajectory name");
}

// A path the controller would refuse (the limits design keeps:
// docs/firmware.md, limits.* and gains.max_torque_Nm, or those the robot
// description gives, on the robot simulated) is an error, or with
// --ignore-limits a warning: a trajectory file always, a built-in path
// where the robot description gives limits.
void check_limits(const SimulateArguments& a, const SimulateOptions& s, std::ostream& err) {
  const bool file = s.trajectory_file.has_value();
  if (!file && !s.robot.limits.any()) return;
  DesignOptions o = default_design_options();
  o.limits = with_robot_limits(o.limits, s.robot.limits);
  const std::string violation = limit_violation(simulated_path(s), s.duration_s, o, s.robot);
  if (violation.empty()) return;
  const std::string path = file ? a.trajectory_file : "the " + s.trajectory + " path";
  const std::string limits = s.robot.limits.any()
                                 ? a.robot_path + "'s limits"
                                 : "docs/firmware.md, limits and gains.max_torque_Nm";
  const std::string what =
      path + ": the trajectory breaks the controller's limits (" + violation + "; " + limits + ")";
  if (!a.ignore_limits) {
    throw delta::InputError(what +
                            ": delta_fw would refuse it. Design one within them (host_id design), "
                            "or give --ignore-limits to simulate it anyway");
  }
  err << "host_id simulate: warning: " << what << "; simulated as --ignore-limits asks\n";
}

// The simulation the options ask for: a trajectory file, a robot, the
// plant, --params; a file outside the controller's limits is refused
// (check_limits).
SimulateOptions simulate_options(const SimulateArguments& a, std::ostream& err) {
  SimulateOptions s = a.simulate;
  if (!a.trajectory_file.empty()) {
    if (a.trajectory_given->count() > 0) {
      throw UsageError("--trajectory-file: not with --trajectory");
    }
    s.trajectory_file = delta::read_trajectory_file(a.trajectory_file);
    s.trajectory = "file";
    if (s.name.empty()) s.name = a.trajectory_file;
    if (a.duration_given->count() == 0) s.duration_s = s.trajectory_file->duration_s();
  }
  if (!a.robot_path.empty()) {
    s.robot = delta::read_robot_description(a.robot_path);
    s.geometry = s.robot.geometry;
    s.parameters = delta::lumped_truth(s.robot);
  }
  if (a.plant == "mujoco") {
    if (!a.params_path.empty()) throw UsageError("--params: only with --plant lumped");
    s.plant = SimulatedPlant::kMujoco;
  }
  if (!a.params_path.empty()) s.parameters = delta::read_lumped_parameters(a.params_path);
  check_limits(a, s, err);
  return s;
}

// The log's PREFIXrms_rad_1..3 and PREFIXmax_rad_1..3 (simulate's
// follower: tracking_, and arm_tracking_ with the arms' encoders) as
// "rms_rad=a,b,c max_rad=a,b,c"; "" where it has none.
std::string tracking_of(const DeltaLog& log, const std::string& prefix) {
  std::string text;
  for (const char* kind : {"rms", "max"}) {
    text += std::string(text.empty() ? "" : " ") + kind + "_rad=";
    for (int j = 1; j <= 3; ++j) {
      const auto v = log.metadata_value(prefix + kind + "_rad_" + std::to_string(j));
      if (!v) return "";
      text += (j == 1 ? "" : ",") + *v;
    }
  }
  return text;
}

// What was written: a JSON summary (--json) or one line (and the tracking
// lines of a followed path).
void print_simulated(const SimulateArguments& a, const SimulateOptions& s, const DeltaLog& log,
                     std::ostream& out) {
  if (a.json) {
    out << nlohmann::json{{"out", a.out_path},
                          {"samples", log.size()},
                          {"trajectory", s.trajectory},
                          {"plant", a.plant},
                          {"duration_s", s.duration_s},
                          {"sample_rate_hz", s.sample_rate_hz},
                          {"torque_noise", s.torque_noise},
                          {"encoder_bits", s.encoder_bits},
                          {"tracking", tracking_of(log, "tracking_")},
                          {"arm_tracking", tracking_of(log, "arm_tracking_")}}
               .dump(2)
        << "\n";
  } else {
    out << "host_id simulate: wrote " << a.out_path << " (" << log.size() << " samples, "
        << s.trajectory << ")\n";
    for (const auto& [line, prefix] :
         {std::pair{"tracking", "tracking_"}, std::pair{"arm tracking", "arm_tracking_"}}) {
      const std::string t = tracking_of(log, prefix);
      if (!t.empty()) out << line << ": " << t << "\n";
    }
  }
}

int run_simulate(const SimulateArguments& a, CommandContext& context) {
  SimulateOptions s = simulate_options(a, context.err);
  ProgressBar bar("simulate", a.quiet || a.json);
  s.progress = [&bar](std::size_t done, std::size_t total) { bar.show(done, total, "samples"); };
  const DeltaLog log = simulate_log(s);
  bar.finish();
  write_delta_log_atomically(a.out_path, log);
  print_simulated(a, s, log, context.out);
  return 0;
}

}  // namespace

void add_simulate_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "Writes a delta-log/1 file with known truth. --plant lumped (the default): the torques by "
      "inverse dynamics of the lumped model (the default robot's parameters, those of --robot, "
      "or --params). --plant mujoco: the multibody robot of --robot (default: the built-in "
      "robot) follows the path under a stiff PD controller with feed-forward, and the log has "
      "the torques applied.");
  auto a = std::make_shared<SimulateArguments>();
  c->add_option("-o,--out", a->out_path, "the log to write (atomically)")
      ->check(kOutputPath)
      ->required();
  add_path_options(*c, a->simulate);
  add_measurement_options(*c, a->simulate);
  c->add_option("--plant", a->plant, "lumped (inverse dynamics) or mujoco (multibody, followed)")
      ->check(CLI::IsMember({"lumped", "mujoco"}))
      ->capture_default_str();
  c->add_option("--robot", a->robot_path, "the robot description (docs/robot-description.md)");
  c->add_option("--params", a->params_path,
                "with --plant lumped: parameters, JSON (keys as in 'host_id fit' output)");
  c->add_option("--trajectory-file", a->trajectory_file,
                "a trajectory file (docs/trajectory-file.md, from host_id design) instead of "
                "--trajectory: run from rest to rest as the controller runs it; --duration "
                "defaults to its length");
  c->add_flag("--ignore-limits", a->ignore_limits,
              "simulate a --trajectory-file that breaks the controller's limits (joint range, "
              "velocity, acceleration, workspace, torque), with a warning instead of an error");
  c->add_flag("--quiet", a->quiet, "no progress bar");
  c->add_flag("--json", a->json, "print a JSON summary instead of text (no progress bar)");
  a->duration_given = c->get_option("--duration");
  a->trajectory_given = c->get_option("--trajectory");
  c->callback([a, &context] { context.exit_code = run_simulate(*a, context); });
}

}  // namespace host_id
