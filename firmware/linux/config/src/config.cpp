#include "fw_linux/config.hpp"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <map>
#include <set>
#include <sstream>
#include <vector>

#include "config_keys.hpp"
#include "delta/can/protocol.hpp"
#include "delta/canopen/eds.hpp"
#include "delta/custom_trajectory_block.hpp"
#include "delta/dynamics.hpp"
#include "delta/input_error.hpp"
#include "delta/model_q.hpp"
#include "delta/q_conversion.hpp"
#include "delta/trajectory_file.hpp"
#include "fw_linux/collision_setting.hpp"
#include "fw_linux/drive_plan.hpp"

namespace fw_linux {
namespace {

const std::map<std::string, ConfigSetter>& setters() {
  return config_setters();
}

std::string trim(const std::string& s, std::size_t& first) {
  first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) {
    first = s.size();
    return {};
  }
  const std::size_t last = s.find_last_not_of(" \t\r");
  return s.substr(first, last - first + 1);
}

// A problem of the configuration as a whole, kept with the others.
void require(std::vector<std::string>& problems, bool ok, const std::string& message) {
  if (!ok) problems.push_back(message);
}

// The torque constant rated_torque / rated_current in its Q format (Q7.24)
// must keep three significant digits; a tiny one would round to 0 and make
// every torque 0.
void require_representable_torque_constant(std::vector<std::string>& problems, const std::string& p,
                                           const delta::DriveModel& m) {
  const double kt = m.torque_constant_Nm_per_A();
  const double q = std::ldexp(std::round(std::ldexp(kt, 24)), -24);
  if (!(std::fabs(q - kt) <= 1e-3 * kt)) {
    std::ostringstream msg;
    msg << p << "rated_torque_Nm / " << p << "rated_current_A = " << kt
        << " N m/A is below what its Q7.24 format keeps to 0.1 % ("
        << std::ldexp(1.0, -24) / 1e-3 * 0.5 << " N m/A)";
    problems.push_back(msg.str());
  }
}

}  // namespace

template <class Q>
Q to_q(double v, const char* what) {
  if (const auto q = delta::to_q<Q>(v)) return *q;
  std::ostringstream m;
  m << what << " = " << v << " does not fit Q" << Q::kIntBits << "." << Q::kFracBits
    << " (range +/- " << std::ldexp(1.0, Q::kIntBits) << ")";
  throw ConfigError(m.str());
}

template delta::fx::Q3_28 to_q<delta::fx::Q3_28>(double, const char*);
template delta::fx::Q7_24 to_q<delta::fx::Q7_24>(double, const char*);
template delta::fx::Q10_21 to_q<delta::fx::Q10_21>(double, const char*);
template delta::fx::Q12_19 to_q<delta::fx::Q12_19>(double, const char*);
template delta::fx::Q14_17 to_q<delta::fx::Q14_17>(double, const char*);
template delta::fx::Q16_15 to_q<delta::fx::Q16_15>(double, const char*);
template delta::fx::Q1_30 to_q<delta::fx::Q1_30>(double, const char*);

namespace {

// Edits (insert, delete, replace a character, case aside) from a to b.
std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const bool same = std::tolower(static_cast<unsigned char>(a[i - 1])) ==
                        std::tolower(static_cast<unsigned char>(b[j - 1]));
      const std::size_t next = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (same ? 0 : 1)});
      diagonal = row[j];
      row[j] = next;
    }
  }
  return row[b.size()];
}

// The known key nearest a mistyped one, where one is near (at most two
// edits, case aside): " (did you mean 'KEY'?)", else "".
std::string did_you_mean(const std::string& key) {
  std::string best;
  std::size_t best_distance = 3;
  for (const auto& [known, setter] : setters()) {
    const std::size_t d = edit_distance(key, known);
    if (d < best_distance) {
      best_distance = d;
      best = known;
    }
  }
  return best.empty() ? "" : " (did you mean '" + best + "'?)";
}

}  // namespace

void set_config_value(PortConfig& c, const std::string& key, const std::string& value,
                      const std::string& where) {
  const auto it = setters().find(key);
  if (it == setters().end()) {
    throw ConfigError(where + ": unknown key '" + key + "'" + did_you_mean(key) +
                      " (docs/firmware.md lists the keys)");
  }
  it->second(c, value, where);
  c.set_where[key] = where;
}

// The EDS's non-zero defaults of 0x6075, 0x6076 and 0x608F:1 where the
// configuration does not set the rated current, torque and encoder
// resolution (the bring-up reads and checks the drive's own).
void adopt_eds_values(PortConfig& c) {
  for (JointDrive& jd : c.joints) {
    if (!jd.eds) continue;
    const auto given = [&jd](std::uint16_t index,
                             std::uint8_t sub) -> std::optional<std::uint64_t> {
      const delta::canopen::EdsVariable* v = jd.eds->find(index, sub);
      if (v == nullptr || v->opaque) return std::nullopt;
      const auto value = v->value(jd.node);
      return value && *value != 0 && *value <= 0xFFFFFFFFu ? value : std::nullopt;
    };
    if (const auto v = given(0x6075, 0); v && !jd.rated_current_set)
      jd.model.rated_current_A = static_cast<double>(*v) / 1000.0;
    if (const auto v = given(0x6076, 0); v && !jd.rated_torque_set)
      jd.model.rated_torque_Nm = static_cast<double>(*v) / 1000.0;
    if (const auto v = given(0x608F, 1); v && !jd.counts_per_rev_set && *v <= (1u << 30))
      jd.model.counts_per_rev = static_cast<std::uint32_t>(*v);
  }
}

// One line of a configuration file into c. Throws ConfigError.
void read_config_line(PortConfig& c, const std::string& line, const std::string& at,
                      std::set<std::string>& seen) {
  std::size_t col = 0;
  const std::string text = trim(line.substr(0, line.find('#')), col);
  if (text.empty()) return;
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos) {
    throw ConfigError(at + std::to_string(col + 1) + ": expected 'key = value'");
  }
  std::size_t key_col = 0;
  std::size_t value_col = 0;
  const std::string key = trim(text.substr(0, eq), key_col);
  const std::string value = trim(text.substr(eq + 1), value_col);
  const std::string key_at = at + std::to_string(col + key_col + 1);
  if (key.empty()) throw ConfigError(key_at + ": a key is missing before '='");
  if (!seen.insert(key).second) throw ConfigError(key_at + ": '" + key + "' is set twice");
  if (setters().count(key) == 0) set_config_value(c, key, value, key_at);  // throws: unknown
  set_config_value(c, key, value, at + std::to_string(col + eq + 1 + value_col + 1));
}

void read_config_lines(PortConfig& c, const std::string& path, std::vector<std::string>* problems) {
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the configuration file");
  std::set<std::string> seen;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    try {
      read_config_line(c, line, path + ":" + std::to_string(n) + ":", seen);
    } catch (const ConfigError& e) {
      if (problems == nullptr) throw;
      problems->emplace_back(e.what());
    }
  }
}

PortConfig read_port_config(const std::string& path, std::vector<std::string>* problems) {
  PortConfig c;
  read_config_lines(c, path, problems);
  finish_config(c, problems);
  return c;
}

void finish_config(PortConfig& c, std::vector<std::string>* problems) {
  std::vector<std::string> robot_problems;
  adopt_robot(c, robot_problems);
  if (problems == nullptr && !robot_problems.empty()) throw ConfigError(robot_problems.front());
  if (problems != nullptr)
    problems->insert(problems->end(), robot_problems.begin(), robot_problems.end());
  adopt_eds_values(c);
  if (c.feed_forward_model && !c.feed_forward_set) c.feed_forward = fw::FeedForwardMode::kModel;
  if (problems == nullptr) return validate(c);
  for (std::string& p : configuration_problems(c)) problems->push_back(std::move(p));
}

namespace {

// The collision detector's keys on their own; whether the model in use
// lets the detector run is collision_setting()'s, at start.
void validate_collision(const PortConfig& c, std::vector<std::string>& problems) {
  if (!(c.collision_threshold_scale > 0.0) || c.collision_threshold_scale > 100.0) {
    problems.push_back("collision.threshold_scale must be above 0 and at most 100, got " +
                       std::to_string(c.collision_threshold_scale));
  }
  if (c.collision_threshold_Nm.value_or(1.0) <= 0.0) {
    problems.push_back("collision.threshold_Nm must be above 0, got " +
                       std::to_string(*c.collision_threshold_Nm));
  }
  if (c.collision_threshold_per_speed < 0.0 || c.collision_threshold_per_acceleration < 0.0) {
    problems.push_back("collision.threshold_per_* must not be negative");
  }
  if (!c.collision_threshold_Nm &&
      (c.collision_threshold_per_speed != 0.0 || c.collision_threshold_per_acceleration != 0.0)) {
    problems.push_back(
        "collision.threshold_per_speed_Nm_s_per_rad and _per_acceleration_Nm_s2_per_rad go with "
        "collision.threshold_Nm (the keys' thresholds replace the model's whole): set it too, or "
        "leave the three out to use the model's");
  }
  if (c.collision_detect.value_or(false) && c.feed_forward != fw::FeedForwardMode::kModel) {
    problems.push_back(
        "collision.detect = true needs feed_forward = model: the detector compares the measured "
        "torque with the identified model's (docs/safety.md)");
  }
}

// The identified model where the feed-forward is to use it: there, and
// fitted for this robot with values the controller holds.
void validate_feed_forward(const PortConfig& c, std::vector<std::string>& problems) {
  if (c.feed_forward == fw::FeedForwardMode::kModel && !c.feed_forward_model) {
    problems.push_back(
        "feed_forward = model needs feed_forward.model = RESULT.json (a model saved by "
        "host_id fit LOG.csv --out RESULT.json)");
  }
  if (!c.feed_forward_model) return;
  for (const std::string& p : delta::model_problems(*c.feed_forward_model, c.geometry)) {
    problems.push_back("feed_forward.model " + c.feed_forward_model_file + ": " + p);
  }
}

// The cycle, the limits, the gains and the heartbeats.
void validate_control(const PortConfig& c, std::vector<std::string>& problems) {
  require(problems, 1000000 % c.period_us == 0,
          "period_us = " + std::to_string(c.period_us) + " must divide one second exactly");
  require(problems, c.response_window_us < c.period_us,
          "response_window_us must be shorter than period_us");
  const std::string geometry = delta::describe_geometry_fault(c.geometry);
  require(problems, geometry.empty(), "geometry: " + geometry);
  require(problems, c.min_rad < c.max_rad, "limits.min_rad must be below limits.max_rad");
  require(problems,
          c.max_velocity_rad_s > 0 && c.max_acceleration_rad_s2 > 0 && c.max_tracking_error_rad > 0,
          "limits: velocity, acceleration and tracking limits must be positive");
  require(problems, c.kp_Nm_per_rad >= 0 && c.kd_Nm_s_per_rad >= 0 && c.ki_Nm_per_rad_s >= 0,
          "gains must not be negative");
  require(problems, c.max_torque_Nm > 0, "gains.max_torque_Nm must be positive");
  require(problems, c.approach_s > 0 && c.stop_s > 0 && c.blend_s > 0,
          "approach_s, stop_s and blend_s must be positive");
  require(problems, c.heartbeat_timeout_ms > c.heartbeat_ms,
          "heartbeat_timeout_ms must be longer than heartbeat_ms");
  // The heartbeat leaves after a control step: every heartbeat_ms rounded
  // up to whole cycles. The drives must not time out between two.
  const std::uint64_t heartbeat_interval_us =
      (std::uint64_t{c.heartbeat_ms} * 1000 + c.period_us - 1) / c.period_us * c.period_us;
  require(problems,
          c.controller_heartbeat_timeout_ms == 0 ||
              (c.heartbeat_ms != 0 &&
               std::uint64_t{c.controller_heartbeat_timeout_ms} * 1000 > heartbeat_interval_us),
          "controller_heartbeat_timeout_ms must be 0 (off) or longer than heartbeat_ms: the "
          "controller's heartbeat comes every " +
              std::to_string(heartbeat_interval_us / 1000) +
              " ms (heartbeat_ms = " + std::to_string(c.heartbeat_ms) +
              " in whole cycles of period_us = " + std::to_string(c.period_us) +
              "), and controller_heartbeat_timeout_ms = " +
              std::to_string(c.controller_heartbeat_timeout_ms));
}

// Each joint's drive: its model, its node, its SYNC counter.
void validate_joints(const PortConfig& c, std::vector<std::string>& problems) {
  for (unsigned j = 0; j < 3; ++j) {
    const std::string p = "joint" + std::to_string(j + 1) + ".";
    const delta::DriveModel& m = c.joints[j].model;
    require(problems, m.gear_ratio > 0, p + "gear_ratio must be positive");
    require(problems, m.rated_current_A > 0 && m.rated_torque_Nm > 0,
            p + "rated_current_A and rated_torque_Nm must be positive");
    require(problems, m.gearbox_efficiency > 0 && m.gearbox_efficiency <= 1,
            p + "gearbox_efficiency must be in (0, 1]");
    require_representable_torque_constant(problems, p, m);
    for (unsigned k = 0; k < j; ++k) {
      require(problems, c.joints[k].node != c.joints[j].node,
              p + "node = " + std::to_string(c.joints[j].node) + " is also joint" +
                  std::to_string(k + 1) + "'s node");
    }
  }
}

// The Modbus address and the GPIO lines.
void validate_io(const PortConfig& c, std::vector<std::string>& problems) {
  try {
    if (!c.modbus.tcp.empty()) (void)split_host_port(c.modbus.tcp, "modbus.tcp");
  } catch (const ConfigError& e) {
    problems.emplace_back(e.what());
  }
  if (!c.gpio.chip.empty()) {
    const std::uint32_t l[] = {c.gpio.estop_line, c.gpio.enable_line, c.gpio.brake_line,
                               c.gpio.status_line};
    const char* names[] = {"estop_line", "enable_line", "brake_line", "status_line"};
    for (unsigned i = 0; i < 4; ++i) {
      for (unsigned k = 0; k < i; ++k) {
        require(problems, l[i] != l[k],
                std::string("gpio.") + names[i] + " = " + std::to_string(l[i]) + " is also gpio." +
                    names[k]);
      }
    }
  }
}

}  // namespace

namespace {

// The problem with its joint's number written N ("joint2." -> "jointN."),
// and that joint (1 to 3); joint 0 where it names no joint or several.
std::pair<std::string, int> joint_free(const std::string& problem) {
  std::string text = problem;
  int joint = 0;
  for (std::size_t at = text.find("joint"); at != std::string::npos;
       at = text.find("joint", at + 5)) {
    if (at + 5 >= text.size() || text[at + 5] < '1' || text[at + 5] > '3') continue;
    const int j = text[at + 5] - '0';
    if (joint != 0 && joint != j) return {problem, 0};
    joint = j;
    text[at + 5] = 'N';
  }
  return {text, joint};
}

// The problems in the order a user fixes them: what keeps a drive or the
// controller from serving first, then the values to set ("... is not
// set"); a problem that several joints share (the same file on each) once,
// naming the joints.
std::vector<std::string> grouped_problems(const std::vector<std::string>& problems) {
  struct Group {
    std::string joint_free;  // the text with jointN; empty: not shared
    std::string first;       // the first problem as it is
    std::vector<int> joints;
  };
  std::vector<Group> groups;  // in first-seen order
  for (const std::string& p : problems) {
    // Not a structured binding: C++20 lambdas cannot capture one.
    const std::pair<std::string, int> free = joint_free(p);
    const std::string& text = free.first;
    const int joint = free.second;
    const auto same = std::find_if(groups.begin(), groups.end(), [&](const Group& g) {
      return joint != 0 && g.joint_free == text;
    });
    if (same != groups.end()) {
      same->joints.push_back(joint);
    } else {
      groups.push_back({joint != 0 ? text : std::string(), p, {joint}});
    }
  }
  std::vector<std::string> fatal, to_set;
  for (const Group& g : groups) {
    std::string line = g.first;
    if (g.joints.size() > 1) {
      std::string names;
      for (std::size_t i = 0; i < g.joints.size(); ++i) {
        names += (i == 0                     ? ""
                  : i + 1 == g.joints.size() ? " and "
                                             : ", ") +
                 std::to_string(g.joints[i]);
      }
      line = "joints " + names + ": " + g.joint_free;
    }
    (line.find(" is not set") != std::string::npos ? to_set : fatal).push_back(line);
  }
  fatal.insert(fatal.end(), to_set.begin(), to_set.end());
  return fatal;
}

}  // namespace

std::vector<std::string> configuration_problems(const PortConfig& c) {
  std::vector<std::string> problems;
  validate_control(c, problems);
  validate_joints(c, problems);
  validate_io(c, problems);
  validate_feed_forward(c, problems);
  validate_collision(c, problems);
  try {
    (void)controller_config(c);  // every value fits its Q format
  } catch (const ConfigError& e) {
    problems.emplace_back(e.what());
  }
  for (std::string& p : plan_drives(c).problems) problems.push_back(std::move(p));
  return grouped_problems(problems);
}

std::string describe_feed_forward(const PortConfig& c) {
  switch (c.feed_forward) {
    case fw::FeedForwardMode::kOff:
      return "feed-forward: off (the PID alone)";
    case fw::FeedForwardMode::kNominal: {
      const fw::ControllerConfig core = controller_config(c);
      std::ostringstream s;
      s << "feed-forward: nominal (arm inertia "
        << core.feed_forward.nominal.arm_inertia_kg_m2.raw() / 524288.0
        << " kg m^2, gravity moment "
        << core.feed_forward.nominal.gravity_moment_Nm.raw() / 524288.0 << " N m)";
      return s.str();
    }
    case fw::FeedForwardMode::kModel:
      break;
  }
  char id[16];
  std::snprintf(id, sizeof id, "0x%08X", c.feed_forward_model ? c.feed_forward_model->fit_id : 0u);
  std::string line = "feed-forward: model (" +
                     (c.feed_forward_model ? c.feed_forward_model->kind : "none") + ", fit " + id +
                     ", " + c.feed_forward_model_file + ")";
  const std::string deflection = describe_deflection(controller_config(c).feed_forward);
  if (!deflection.empty()) line += "; " + deflection;
  const std::string left_out =
      c.feed_forward_model ? delta::left_out_by_controller(*c.feed_forward_model) : "";
  return left_out.empty() ? line : line + "; note: " + left_out;
}

std::string describe_deflection(const fw::FeedForwardConfig& f) {
  if (f.mode != fw::FeedForwardMode::kModel) return "";
  const auto& c = f.model.parameters.gearbox_compliance_rad_per_Nm;
  std::string stiffness;
  bool elastic = false;
  for (unsigned j = 0; j < 3; ++j) {
    const double compliance = std::ldexp(static_cast<double>(c[j].raw()), -30);
    char k[32] = "rigid";
    if (compliance > 0) std::snprintf(k, sizeof k, "%.0f", 1.0 / compliance);
    stiffness += (j == 0 ? "" : ", ") + std::string(k);
    elastic = elastic || compliance > 0;
  }
  if (!elastic) return "";
  return fw::compensates_deflection(f)
             ? "deflection compensation on (gearbox stiffness " + stiffness + " N m/rad)"
             : "deflection compensation off (feed_forward.deflection_compensation = false; the "
               "model's gearbox stiffness is " +
                   stiffness + " N m/rad)";
}

void validate(const PortConfig& c) {
  const std::vector<std::string> problems = configuration_problems(c);
  if (problems.empty()) return;
  std::string text = problems.front();
  for (std::size_t i = 1; i < problems.size(); ++i) text += "\n" + problems[i];
  throw ConfigError(text);
}

std::pair<std::string, int> split_host_port(const std::string& text, const std::string& what) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == text.size()) {
    throw ConfigError(what + ": expected ADDRESS:PORT, got '" + text + "'");
  }
  const std::string port = text.substr(colon + 1);
  char* end = nullptr;
  errno = 0;
  const long p = std::strtol(port.c_str(), &end, 10);
  if (end != port.c_str() + port.size() || errno != 0 || p < 0 || p > 65535) {
    throw ConfigError(what + ": the port must be a number from 0 to 65535, got '" + port + "'");
  }
  return {text.substr(0, colon), static_cast<int>(p)};
}

namespace {

// The feed-forward of configuration c on geometry g: the nominal one of
// the robot description (robot = FILE) or else the default robot (the arm
// plus a third of the platform at each elbow) unless its keys are given,
// the mode, and the model where there is one.
fw::FeedForwardConfig feed_forward_config(const PortConfig& c, const fw::GeometryQ& g) {
  using namespace delta::fx;
  fw::FeedForwardConfig f;
  const delta::LumpedParameters p =
      c.robot ? delta::lumped_truth(*c.robot) : delta::default_lumped_parameters();
  const double a = c.geometry.upper_arm_length_m;
  const double inertia = c.nominal_arm_inertia_kg_m2 >= 0
                             ? c.nominal_arm_inertia_kg_m2
                             : p.arm_inertia_kg_m2[0] + p.platform_mass_kg * a * a / 3.0;
  const double gravity =
      c.nominal_gravity_moment_Nm >= 0
          ? c.nominal_gravity_moment_Nm
          : p.arm_gravity_moment_Nm[0] + p.platform_mass_kg * p.gravity_m_s2 * a / 3.0;
  f.nominal.arm_inertia_kg_m2 = to_q<Q12_19>(inertia, "nominal.arm_inertia_kg_m2");
  f.nominal.gravity_moment_Nm = to_q<Q12_19>(gravity, "nominal.gravity_moment_Nm");
  f.mode = c.feed_forward;
  f.deflection_compensation = c.deflection_compensation;
  if (c.feed_forward_model) {
    f.model = prepare_model(g, delta::model_parameters_q(*c.feed_forward_model));
  }
  return f;
}

}  // namespace

fw::ControllerConfig controller_config(const PortConfig& c) {
  using namespace delta::fx;
  fw::ControllerConfig out;
  out.geometry = {to_q<Q7_24>(c.geometry.upper_arm_length_m, "geometry.upper_arm_length_m"),
                  to_q<Q7_24>(c.geometry.forearm_length_m, "geometry.forearm_length_m"),
                  to_q<Q7_24>(c.geometry.base_radius_m, "geometry.base_radius_m"),
                  to_q<Q7_24>(c.geometry.platform_radius_m, "geometry.platform_radius_m")};
  out.tick_period_us = c.period_us;
  out.limits.min_rad = to_q<Q3_28>(c.min_rad, "limits.min_rad");
  out.limits.max_rad = to_q<Q3_28>(c.max_rad, "limits.max_rad");
  out.limits.max_velocity_rad_s = to_q<Q10_21>(c.max_velocity_rad_s, "limits.max_velocity_rad_s");
  out.limits.max_acceleration_rad_s2 =
      to_q<Q14_17>(c.max_acceleration_rad_s2, "limits.max_acceleration_rad_s2");
  out.max_tracking_error_rad =
      to_q<Q3_28>(c.max_tracking_error_rad, "limits.max_tracking_error_rad");
  out.gains.kp_Nm_per_rad = to_q<Q16_15>(c.kp_Nm_per_rad, "gains.kp_Nm_per_rad");
  out.gains.kd_Nm_s_per_rad = to_q<Q12_19>(c.kd_Nm_s_per_rad, "gains.kd_Nm_s_per_rad");
  out.gains.ki_Nm_per_rad_s = to_q<Q16_15>(c.ki_Nm_per_rad_s, "gains.ki_Nm_per_rad_s");
  out.gains.max_torque_Nm = to_q<Q12_19>(c.max_torque_Nm, "gains.max_torque_Nm");
  out.gains.integral_limit_Nm = to_q<Q12_19>(c.integral_limit_Nm, "gains.integral_limit_Nm");
  out.feed_forward = feed_forward_config(c, out.geometry);
  out.collision =
      collision_setting(
          c, c.feed_forward == fw::FeedForwardMode::kModel && c.feed_forward_model.has_value(),
          model_thresholds(c))
          .config;
  for (unsigned j = 0; j < 3; ++j) {
    const delta::DriveModel& m = c.joints[j].model;
    fw::JointTorqueConfig& t = out.torque[j];
    t.gear_ratio = to_q<Q12_19>(m.gear_ratio, "gear_ratio");
    t.torque_constant_Nm_per_A = to_q<Q7_24>(m.torque_constant_Nm_per_A(), "torque constant");
    t.efficiency = to_q<Q1_30>(m.gearbox_efficiency, "gearbox_efficiency");
    t.inverted = m.inverted;
    t.offset_Nm = to_q<Q12_19>(c.joints[j].torque_offset_Nm, "torque_offset_Nm");
  }
  const double ticks_per_s = 1e6 / c.period_us;
  out.approach_ticks = static_cast<std::uint32_t>(std::lround(c.approach_s * ticks_per_s));
  out.stop_ticks = static_cast<std::uint32_t>(std::lround(c.stop_s * ticks_per_s));
  out.configure_timeout_ticks =
      static_cast<std::uint32_t>(std::lround(c.configure_timeout_ms * 1e3 / c.period_us));
  out.lost_feedback_ticks = c.lost_feedback_cycles;
  return out;
}

}  // namespace fw_linux
