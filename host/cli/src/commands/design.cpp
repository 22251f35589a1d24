// host_id design -o TRAJ.json: an excitation designed for the robot.
#include "host_id/design.hpp"

#include <cmath>
#include <memory>
#include <nlohmann/json.hpp>
#include <ostream>
#include <sstream>

#include "commands/command.hpp"
#include "commands/progress.hpp"
#include "delta/atomic_file.hpp"
#include "delta/controller/vocabulary.hpp"
#include "delta/robot_description.hpp"
#include "delta/trajectory_file.hpp"

namespace host_id {

namespace {

struct DesignArguments {
  std::string out_path;
  std::string robot_path;
  std::string criterion{"cond"};
  std::string compare{"path1"};
  std::vector<double> centre{0.0, 0.0, -0.42};
  bool json{false};
  bool quiet{false};
  DesignOptions design{default_design_options()};
  // Each limit's option, given or not: the robot description's limits
  // (--robot) hold where the option is not given.
  std::vector<CLI::Option*> limit_options;
};

void add_trajectory_options(CLI::App& c, DesignArguments& a) {
  DesignOptions& d = a.design;
  const char* g = "trajectory";
  c.add_option("--harmonics", d.harmonics, "Fourier harmonics (the controller takes up to 6)")
      ->check(CLI::Range(1, 6))
      ->capture_default_str()
      ->group(g);
  c.add_option("--base-hz", d.base_frequency_hz, "base frequency, Hz (a whole number of mHz)")
      ->check(finite_range(0.01, 2.0))
      ->capture_default_str()
      ->group(g);
  c.add_option("--blend", d.blend_s, "fade in from rest and out to rest over this, s")
      ->check(finite_range(0.0, 60.0) & kPositive)
      ->capture_default_str()
      ->group(g);
  c.add_option("--periods", d.periods, "whole periods between the blends")
      ->check(CLI::Range(1, 100))
      ->capture_default_str()
      ->group(g);
  c.add_option("--centre", a.centre, "X,Y,Z of the platform about which the joints move, m")
      ->expected(3)
      ->delimiter(',')
      ->check(kFinite)
      ->group(g);
  c.add_option("--max-amplitude", d.max_amplitude_rad,
               "search box: harmonic k's position amplitude at most this / k, rad")
      ->check(finite_range(0.0, 1.5) & kPositive)
      ->capture_default_str()
      ->group(g);
}

void add_limit_options(CLI::App& c, DesignArguments& a) {
  DesignLimits& l = a.design.limits;
  const char* g =
      "limits (the robot description's where --robot gives them, else the controller's "
      "defaults)";
  a.limit_options = {
      c.add_option("--min-rad", l.min_rad, "joint range, lower end")->check(kFinite),
      c.add_option("--max-rad", l.max_rad, "joint range, upper end")->check(kFinite),
      c.add_option("--max-velocity", l.max_velocity_rad_s, "rad/s")->check(kPositive),
      c.add_option("--max-acceleration", l.max_acceleration_rad_s2, "rad/s^2")->check(kPositive),
      c.add_option("--max-torque", l.max_torque_Nm,
                   "joint torque with the robot's nominal parameters, N m")
          ->check(kPositive)};
  for (CLI::Option* o : a.limit_options) o->capture_default_str()->group(g);
}

// The robot description's limits where no option gives them.
void adopt_robot_limits(DesignArguments& a, const delta::RobotLimits& robot) {
  DesignLimits& l = a.design.limits;
  const DesignLimits from_robot = with_robot_limits(l, robot);
  double DesignLimits::*const fields[] = {
      &DesignLimits::min_rad, &DesignLimits::max_rad, &DesignLimits::max_velocity_rad_s,
      &DesignLimits::max_acceleration_rad_s2, &DesignLimits::max_torque_Nm};
  for (std::size_t i = 0; i < a.limit_options.size(); ++i) {
    if (a.limit_options[i]->count() == 0) l.*fields[i] = from_robot.*fields[i];
  }
}

void add_search_options(CLI::App& c, DesignArguments& a) {
  DesignOptions& d = a.design;
  const char* g = "search";
  c.add_option("--model", d.model.name, "the model whose regressor is conditioned")
      ->check(CLI::IsMember({"delta", "lumped"}))
      ->capture_default_str()
      ->group(g);
  c.add_option("--criterion", a.criterion,
               "cond: minimise the condition number of the column-scaled regressor; logdet: "
               "maximise the log determinant of its information matrix; calibration: a run for "
               "fit --calibrate-torque (run it empty and with the payload): the condition "
               "number over the square of the weakest joint's RMS payload torque")
      ->check(CLI::IsMember({"cond", "logdet", "calibration"}))
      ->capture_default_str()
      ->group(g);
  c.add_option("--particles", d.pso.particles, "PSO particles")
      ->check(CLI::Range(2, 10000))
      ->capture_default_str()
      ->group(g);
  c.add_option("--iterations", d.pso.iterations, "PSO iterations at most")
      ->check(CLI::Range(1, 1000000))
      ->capture_default_str()
      ->group(g);
  c.add_option("--seed", d.pso.seed, "PSO seed")->capture_default_str()->group(g);
  c.add_option("--torque-noise", d.torque_noise_Nm,
               "for the expected standard deviations: white torque noise, N m")
      ->check(kPositive)
      ->capture_default_str()
      ->group(g);
  c.add_option("--rate", d.log_rate_hz, "... on a log sampled at this rate, Hz")
      ->check(kPositive)
      ->capture_default_str()
      ->group(g);
  c.add_option("--compare", a.compare, "the preset to compare with")
      ->check(CLI::IsMember({"path1", "path2"}))
      ->capture_default_str()
      ->group(g);
}

nlohmann::json quality_json(const ExcitationQuality& q, const Model& model) {
  nlohmann::json params = nlohmann::json::array();
  for (std::size_t i = 0; i < q.std_dev.size(); ++i) {
    params.push_back({{"name", model.parameters()[i].name},
                      {"nominal", q.nominal[i]},
                      {"expected_std_dev", q.std_dev[i]},
                      {"expected_rel_std_percent", std::isfinite(q.rel_std_percent[i])
                                                       ? nlohmann::json(q.rel_std_percent[i])
                                                       : nlohmann::json(nullptr)}});
  }
  return {{"condition_number_scaled", q.condition_number_scaled},
          {"log_det_scaled", q.log_det_scaled},
          {"largest_torque_Nm", q.largest_torque_Nm},
          {"payload_torque_rms_Nm_per_kg", q.payload_torque_rms_Nm_per_kg},
          {"parameters", params}};
}

void print_text(std::ostream& out, const DesignArguments& a, const DesignResult& d,
                const ExcitationQuality& preset, const Model& model) {
  char buf[200];
  out << "host_id design: wrote " << a.out_path << "\n";
  std::snprintf(buf, sizeof buf,
                "  trajectory %u harmonics at %.3f Hz, %u period(s), blends of %.2f s: %.2f s\n",
                a.design.harmonics, a.design.base_frequency_hz, a.design.periods, a.design.blend_s,
                d.trajectory.duration_s());
  out << buf;
  std::snprintf(buf, sizeof buf,
                "  search     PSO, %zu evaluations, %.1f s; largest torque %.3f N m\n",
                d.pso.evaluations, d.seconds, d.quality.largest_torque_Nm);
  out << buf;
  std::snprintf(buf, sizeof buf, "  condition number (columns scaled): %.3g designed, %.3g %s\n",
                d.quality.condition_number_scaled, preset.condition_number_scaled,
                a.compare.c_str());
  out << buf;
  const auto& pd = d.quality.payload_torque_rms_Nm_per_kg;
  const auto& pp = preset.payload_torque_rms_Nm_per_kg;
  std::snprintf(buf, sizeof buf,
                "  RMS payload torque per kg (N m/kg, joints 1-3): %.3g, %.3g, %.3g designed, "
                "%.3g, %.3g, %.3g %s\n",
                pd[0], pd[1], pd[2], pp[0], pp[1], pp[2], a.compare.c_str());
  out << buf;
  std::snprintf(buf, sizeof buf,
                "  expected relative std dev [%%] at %.3g N m torque noise, %.0f Hz "
                "(white noise):\n  %-24s %10s %10s\n",
                a.design.torque_noise_Nm, a.design.log_rate_hz, "parameter", "designed",
                a.compare.c_str());
  out << buf;
  for (std::size_t i = 0; i < d.quality.std_dev.size(); ++i) {
    std::snprintf(buf, sizeof buf, "  %-24s %10.3g %10.3g\n", model.parameters()[i].name.c_str(),
                  d.quality.rel_std_percent[i], preset.rel_std_percent[i]);
    out << buf;
  }
}

// What the controller cannot run: a frequency that is not whole mHz, a
// trajectory longer than it walks.
void check_timing(const DesignOptions& o) {
  const double mHz = o.base_frequency_hz * 1000.0;
  if (std::abs(mHz - std::round(mHz)) > 1e-9 * mHz) {
    throw UsageError("--base-hz: must be a whole number of mHz (the controller's unit)");
  }
  if (const double s = 2.0 * o.blend_s + o.periods / o.base_frequency_hz;
      s * 1000.0 > delta::controller::kMaxTrajectoryTicks) {
    std::ostringstream m;
    m << "--base-hz " << o.base_frequency_hz << " with --periods " << o.periods << " and --blend "
      << o.blend_s << " lasts " << s << " s; the controller runs at most "
      << delta::controller::kMaxTrajectoryTicks / 1000 << " s ("
      << delta::controller::kMaxTrajectoryTicks << " ticks of 1 ms, docs/modbus.md)";
    throw UsageError(m.str());
  }
}

// The design's summary, also the trajectory file's metadata.
nlohmann::json design_json(const DesignArguments& a, const DesignResult& d,
                           const ExcitationQuality& preset, const Model& model) {
  const DesignLimits& l = a.design.limits;
  return {{"by", "host_id design"},
          {"robot", a.robot_path.empty() ? "built-in default" : a.robot_path},
          {"model", a.design.model.name},
          {"criterion", a.criterion},
          {"designed", quality_json(d.quality, model)},
          {"limits",
           {{"min_rad", l.min_rad},
            {"max_rad", l.max_rad},
            {"max_velocity_rad_s", l.max_velocity_rad_s},
            {"max_acceleration_rad_s2", l.max_acceleration_rad_s2},
            {"max_torque_Nm", l.max_torque_Nm}}},
          {"compared_with", a.compare},
          {"preset", quality_json(preset, model)}};
}

int run_design(DesignArguments a, std::ostream& out) {
  a.design.centre_m = {a.centre[0], a.centre[1], a.centre[2]};
  a.design.criterion = a.criterion == "cond"          ? DesignCriterion::kConditionNumber
                       : a.criterion == "calibration" ? DesignCriterion::kCalibration
                                                      : DesignCriterion::kLogDet;
  check_timing(a.design);
  const delta::RobotDescription robot = a.robot_path.empty()
                                            ? delta::default_robot_description()
                                            : delta::read_robot_description(a.robot_path);
  adopt_robot_limits(a, robot.limits);
  if (const DesignLimits& l = a.design.limits; !(l.min_rad < l.max_rad)) {
    std::ostringstream m;
    m << "--min-rad (" << l.min_rad << ") must be below --max-rad (" << l.max_rad
      << ") (with the robot description's limits where an option is not given)";
    throw UsageError(m.str());
  }
  ProgressBar bar("design", a.quiet);
  a.design.pso.progress = [&bar](std::size_t it, std::size_t max, double c) {
    char cost[48];
    std::snprintf(cost, sizeof cost, "cost %.6g", c);
    bar.show(it, max, cost);
  };
  const DesignResult d = design_excitation(a.design, robot);
  bar.finish();
  const ExcitationQuality preset =
      excitation_quality(preset_trajectory(a.compare, robot, a.design.blend_s), a.design, robot);
  const auto model = make_model(a.design.model);
  const nlohmann::json design = design_json(a, d, preset, *model);
  delta::write_file_atomically(a.out_path, delta::format_trajectory(d.trajectory, design.dump()));
  if (a.json) {
    out << design.dump(2) << "\n";
  } else {
    print_text(out, a, d, preset, *model);
  }
  return 0;
}

}  // namespace

void add_design_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "Designs a Fourier excitation by PSO: the coefficients that minimise the condition number "
      "of the model's column-scaled regressor along the whole trajectory (faded in from rest, "
      "whole periods, faded out), with the joint range, velocity, acceleration, workspace and "
      "torque limits respected on every sample. Writes a trajectory file "
      "(docs/trajectory-file.md) and prints the condition number and the parameters' expected "
      "standard deviations beside a preset's.");
  auto a = std::make_shared<DesignArguments>();
  c->add_option("-o,--out", a->out_path, "the trajectory file to write (atomically)")
      ->check(kOutputPath)
      ->required();
  c->add_option("--robot", a->robot_path,
                "the robot description (docs/robot-description.md; default: the built-in robot)");
  c->add_flag("--json", a->json, "print the design's summary as JSON");
  c->add_flag("--quiet", a->quiet, "no progress bar");
  add_trajectory_options(*c, *a);
  add_limit_options(*c, *a);
  add_search_options(*c, *a);
  c->callback([a, &context] { context.exit_code = run_design(*a, context.out); });
}

}  // namespace host_id
