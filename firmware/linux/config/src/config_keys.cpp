// The configuration file's keys (docs/firmware.md): each key's setter
// parses its value, checks its range, and sets it in a PortConfig.
#include "config_keys.hpp"

#include <charconv>
#include <cmath>
#include <map>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>

#include "delta/can/protocol.hpp"
#include "delta/canopen/eds.hpp"
#include "delta/custom_trajectory_block.hpp"
#include "delta/input_error.hpp"
#include "delta/model_q.hpp"
#include "delta/trajectory_file.hpp"

namespace fw_linux {
namespace {

// approach_s, stop_s and blend_s: far beyond any real one, and well inside
// the controller's 32-bit tick counter at the fastest rate (10 kHz).
constexpr double kMaxSeconds = 3600.0;

// A decimal number (an optional sign, digits, a point, an exponent): no
// hexadecimal, no inf or nan, nothing after it.
double parse_number(const std::string& v, const std::string& where, const std::string& key) {
  const char* begin = v.data();
  const char* const end = v.data() + v.size();
  if (begin != end && *begin == '+') ++begin;  // one '+' at most, and not "+-"
  double d = 0.0;
  const auto r = std::from_chars(begin, end, d, std::chars_format::general);
  if (begin == end || *begin == '+' || (begin != v.data() && *begin == '-') ||
      r.ec != std::errc() || r.ptr != end || !std::isfinite(d)) {
    throw ConfigError(where + ": " + key + " needs a decimal number, got '" + v + "'");
  }
  return d;
}

// Where a value must lie: [lo, hi], or (lo, hi] when the low end is open.
struct Range {
  double lo, hi;
  const char* unit;
  bool closed_low;
};

double parse_in_range(const std::string& v, const std::string& where, const std::string& key,
                      const Range& r) {
  const double d = parse_number(v, where, key);
  if (!((r.closed_low ? d >= r.lo : d > r.lo) && d <= r.hi)) {
    std::ostringstream m;
    m << where << ": " << key << " = " << v << r.unit << " is out of range "
      << (r.closed_low ? "[" : "(") << r.lo << ", " << r.hi << "]" << r.unit;
    throw ConfigError(m.str());
  }
  return d;
}

// A number of seconds that becomes a count of control ticks: within
// (0, kMaxSeconds], so that the count fits the controller's 32-bit counter.
std::function<void(PortConfig&, const std::string&, const std::string&)> seconds_setter(
    const std::string& key, double PortConfig::*field) {
  return [key, field](PortConfig& c, const std::string& v, const std::string& w) {
    c.*field = parse_in_range(v, w, key, {0.0, kMaxSeconds, " s", false});
  };
}

std::uint32_t parse_unsigned(const std::string& v, const std::string& where, const std::string& key,
                             std::uint32_t lo, std::uint32_t hi) {
  const double d = parse_number(v, where, key);
  if (d != std::floor(d) || d < lo || d > hi) {
    throw ConfigError(where + ": " + key + " must be a whole number from " + std::to_string(lo) +
                      " to " + std::to_string(hi) + ", got '" + v + "'");
  }
  return static_cast<std::uint32_t>(d);
}

bool parse_bool(const std::string& v, const std::string& where, const std::string& key) {
  if (v == "true" || v == "yes" || v == "1") return true;
  if (v == "false" || v == "no" || v == "0") return false;
  throw ConfigError(where + ": " + key + " must be true or false, got '" + v + "'");
}

using Setter = ConfigSetter;
using Setters = std::map<std::string, Setter>;

// --- the values a key takes in words, each refused with its choices ---

CycleMode parse_cycle_mode(const std::string& v, const std::string& w) {
  if (v == "realtime") return CycleMode::kRealTime;
  if (v == "lockstep") return CycleMode::kLockStep;
  throw ConfigError(w + ": mode must be 'realtime' or 'lockstep', got '" + v + "'");
}

std::uint8_t parse_sync_counter_overflow(const std::string& v, const std::string& w) {
  const std::uint32_t n = parse_unsigned(v, w, "sync_counter_overflow", 0,
                                         delta::can::protocol::kSyncCounterMaxOverflow);
  if (n == 1) {
    throw ConfigError(w + ": sync_counter_overflow must be 0 (no counter) or from 2 to " +
                      std::to_string(delta::can::protocol::kSyncCounterMaxOverflow) +
                      " (CiA 301, 0x1019), got '" + v + "'");
  }
  return static_cast<std::uint8_t>(n);
}

fw::FeedForwardMode parse_feed_forward(const std::string& v, const std::string& w) {
  if (v == "off") return fw::FeedForwardMode::kOff;
  if (v == "nominal") return fw::FeedForwardMode::kNominal;
  if (v == "model") return fw::FeedForwardMode::kModel;
  throw ConfigError(w + ": feed_forward must be off, nominal or model, got '" + v + "'");
}

char parse_rtu_parity(const std::string& v, const std::string& w) {
  if (v == "N" || v == "none") return 'N';
  if (v == "E" || v == "even") return 'E';
  if (v == "O" || v == "odd") return 'O';
  throw ConfigError(w + ": modbus.rtu_parity must be N, E or O (none, even, odd), got '" + v + "'");
}

// `p` is the joint's prefix ("joint2.").
TorqueUnit parse_torque_unit(const std::string& v, const std::string& w, const std::string& p) {
  static const std::map<std::string, TorqueUnit> kUnits = {{"per_mille", TorqueUnit::kPerMille},
                                                           {"mA", TorqueUnit::kMilliamp},
                                                           {"mNm", TorqueUnit::kMilliNewtonMetre}};
  const auto it = kUnits.find(v);
  if (it == kUnits.end()) {
    throw ConfigError(w + ": " + p + "torque_unit must be per_mille, mA or mNm, got '" + v + "'");
  }
  return it->second;
}

// --- the keys that read a file ---

void read_feed_forward_model(PortConfig& c, const std::string& v, const std::string& w) {
  try {
    c.feed_forward_model = delta::read_identified_model(v);
    c.feed_forward_model_file = v;
  } catch (const delta::InputError& e) {
    throw ConfigError(w + ": feed_forward.model: " + e.what());
  }
}

// robot = FILE: the robot description, adopted once the whole
// configuration is read (adopt_robot).
void read_robot(PortConfig& c, const std::string& v, const std::string& w) {
  try {
    c.robot = delta::read_robot_description(v);
    c.robot_file = v;
  } catch (const delta::InputError& e) {
    throw ConfigError(w + ": robot: " + e.what());
  }
}

// The custom trajectory's registers, filled from a delta-trajectory/1 file.
void read_custom_trajectory(PortConfig& c, const std::string& v, const std::string& w) {
  try {
    c.custom_trajectory_file = v;
    c.custom_block = delta::custom_trajectory_block(delta::read_trajectory_file(v));
  } catch (const delta::InputError& e) {
    throw ConfigError(w + ": trajectory_file: " + e.what());
  }
}

// The EDS is read here, and the identity it gives is the one to expect;
// what the drive can do is planned once the whole configuration is read
// (plan_drives).
void read_joint_eds(PortConfig& c, unsigned j, const std::string& p, const std::string& v,
                    const std::string& w) {
  c.joints[j].eds_path = v;
  try {
    c.joints[j].eds = std::make_shared<const delta::canopen::Eds>(delta::canopen::read_eds(v));
  } catch (const delta::canopen::EdsError& e) {
    throw ConfigError(w + ": " + p + "eds: " + e.what());
  }
  DriveIdentity& id = c.joints[j].identity;
  id.vendor_id = c.joints[j].eds->identity.vendor_id;
  id.product_code = c.joints[j].eds->identity.product_code;
  id.revision = c.joints[j].eds->identity.revision;
  id.source = p + "eds = " + v;
}

// --- the table's entries of a kind ---

void add_number(Setters& s, const std::string& key, double PortConfig::*field) {
  s[key] = [key, field](PortConfig& c, const std::string& v, const std::string& w) {
    c.*field = parse_number(v, w, key);
  };
}

void add_geometry(Setters& s, const std::string& key, double delta::Geometry::*field) {
  s[key] = [key, field](PortConfig& c, const std::string& v, const std::string& w) {
    c.geometry.*field = parse_number(v, w, key);
  };
}

void add_whole(Setters& s, const std::string& key, std::uint32_t PortConfig::*field,
               std::uint32_t lo, std::uint32_t hi) {
  s[key] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    c.*field = parse_unsigned(v, w, key, lo, hi);
  };
}

void add_modbus_whole(Setters& s, const std::string& key, std::uint32_t ModbusConfig::*field,
                      std::uint32_t lo, std::uint32_t hi) {
  s[key] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    c.modbus.*field = parse_unsigned(v, w, key, lo, hi);
  };
}

void add_gpio_line(Setters& s, const std::string& key, std::uint32_t GpioConfig::*field,
                   std::uint32_t hi) {
  s[key] = [key, field, hi](PortConfig& c, const std::string& v, const std::string& w) {
    c.gpio.*field = parse_unsigned(v, w, key, 0, hi);
  };
}

void add_joint_number(Setters& s, unsigned j, const std::string& key,
                      double delta::DriveModel::*field, const Range& range,
                      bool JointDrive::*set = nullptr) {
  s[key] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    c.joints[j].model.*field = parse_in_range(v, w, key, range);
    if (set != nullptr) c.joints[j].*set = true;
  };
}

// --- the keys, section by section (docs/firmware.md) ---

// The cycle, the bus's timing and the heartbeats.
void add_cycle_keys(Setters& s) {
  add_whole(s, "period_us", &PortConfig::period_us, 100, 1000000);
  add_whole(s, "can_bitrate", &PortConfig::can_bitrate, 10000, 1000000);
  add_whole(s, "response_window_us", &PortConfig::response_window_us, 0, 1000000);
  add_whole(s, "lockstep_timeout_ms", &PortConfig::lockstep_timeout_ms, 1, 60000);
  add_whole(s, "heartbeat_timeout_ms", &PortConfig::heartbeat_timeout_ms, 1, 60000);
  add_whole(s, "sdo_timeout_ms", &PortConfig::sdo_timeout_ms, 1, 60000);
  add_whole(s, "sdo_retries", &PortConfig::sdo_retries, 0, 10);
  add_whole(s, "lost_feedback_cycles", &PortConfig::lost_feedback_cycles, 1, 1000);
  add_whole(s, "configure_timeout_ms", &PortConfig::configure_timeout_ms, 1, 600000);
  s["heartbeat_ms"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    c.heartbeat_ms = static_cast<std::uint16_t>(parse_unsigned(v, w, "heartbeat_ms", 1, 65535));
  };
  s["controller_heartbeat_timeout_ms"] = [](PortConfig& c, const std::string& v,
                                            const std::string& w) {
    c.controller_heartbeat_timeout_ms = static_cast<std::uint16_t>(
        parse_unsigned(v, w, "controller_heartbeat_timeout_ms", 0, 65535));
  };
  s["mode"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    c.mode = parse_cycle_mode(v, w);
  };
  s["sync_counter_overflow"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    c.sync_counter_overflow = parse_sync_counter_overflow(v, w);
  };
  s["velocity_pdo"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    c.velocity_pdo = parse_bool(v, w, "velocity_pdo");
  };
  s["arm_encoders"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    c.arm_encoders = parse_bool(v, w, "arm_encoders");
  };
}

// The robot's geometry, its limits, the gains and the nominal feed-forward.
void add_motion_keys(Setters& s) {
  s["robot"] = read_robot;
  add_geometry(s, "geometry.upper_arm_length_m", &delta::Geometry::upper_arm_length_m);
  add_geometry(s, "geometry.forearm_length_m", &delta::Geometry::forearm_length_m);
  add_geometry(s, "geometry.base_radius_m", &delta::Geometry::base_radius_m);
  add_geometry(s, "geometry.platform_radius_m", &delta::Geometry::platform_radius_m);
  add_number(s, "limits.min_rad", &PortConfig::min_rad);
  add_number(s, "limits.max_rad", &PortConfig::max_rad);
  add_number(s, "limits.max_velocity_rad_s", &PortConfig::max_velocity_rad_s);
  add_number(s, "limits.max_acceleration_rad_s2", &PortConfig::max_acceleration_rad_s2);
  add_number(s, "limits.max_tracking_error_rad", &PortConfig::max_tracking_error_rad);
  add_number(s, "gains.kp_Nm_per_rad", &PortConfig::kp_Nm_per_rad);
  add_number(s, "gains.kd_Nm_s_per_rad", &PortConfig::kd_Nm_s_per_rad);
  add_number(s, "gains.ki_Nm_per_rad_s", &PortConfig::ki_Nm_per_rad_s);
  add_number(s, "gains.max_torque_Nm", &PortConfig::max_torque_Nm);
  add_number(s, "gains.integral_limit_Nm", &PortConfig::integral_limit_Nm);
  add_number(s, "nominal.arm_inertia_kg_m2", &PortConfig::nominal_arm_inertia_kg_m2);
  add_number(s, "nominal.gravity_moment_Nm", &PortConfig::nominal_gravity_moment_Nm);
}

// The feed-forward, the trajectories' timing and the custom trajectory.
void add_run_keys(Setters& s) {
  s["feed_forward"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    c.feed_forward = parse_feed_forward(v, w);
    c.feed_forward_set = true;
  };
  s["feed_forward.model"] = read_feed_forward_model;
  s["feed_forward.deflection_compensation"] = [](PortConfig& c, const std::string& v,
                                                 const std::string& w) {
    c.deflection_compensation = parse_bool(v, w, "feed_forward.deflection_compensation");
  };
  s["feed_forward.store"] = [](PortConfig& c, const std::string& v, const std::string&) {
    c.feed_forward_store = v;
  };
  s["collision.detect"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    c.collision_detect = parse_bool(v, w, "collision.detect");
  };
  add_number(s, "collision.threshold_scale", &PortConfig::collision_threshold_scale);
  s["collision.threshold_Nm"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    c.collision_threshold_Nm = parse_number(v, w, "collision.threshold_Nm");
  };
  add_number(s, "collision.threshold_per_speed_Nm_s_per_rad",
             &PortConfig::collision_threshold_per_speed);
  add_number(s, "collision.threshold_per_acceleration_Nm_s2_per_rad",
             &PortConfig::collision_threshold_per_acceleration);
  s["approach_s"] = seconds_setter("approach_s", &PortConfig::approach_s);
  s["stop_s"] = seconds_setter("stop_s", &PortConfig::stop_s);
  s["blend_s"] = seconds_setter("blend_s", &PortConfig::blend_s);
  s["trajectory_file"] = read_custom_trajectory;
}

void add_modbus_keys(Setters& s) {
  s["modbus.tcp"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    if (!v.empty()) (void)split_host_port(v, w + ": modbus.tcp");
    c.modbus.tcp = v;
  };
  s["modbus.allow"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    (void)parse_allow_list(v, w);
    c.modbus.allow = v;
  };
  s["modbus.rtu_device"] = [](PortConfig& c, const std::string& v, const std::string&) {
    c.modbus.rtu_device = v;
  };
  s["modbus.rtu_parity"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    c.modbus.rtu_parity = parse_rtu_parity(v, w);
  };
  add_modbus_whole(s, "modbus.rtu_baud", &ModbusConfig::rtu_baud, 1200, 4000000);
  add_modbus_whole(s, "modbus.rtu_unit_id", &ModbusConfig::rtu_unit_id, 1, 247);
  add_modbus_whole(s, "modbus.max_clients", &ModbusConfig::max_clients, 1, 256);
  add_modbus_whole(s, "modbus.byte_timeout_ms", &ModbusConfig::byte_timeout_ms, 1, 10000);
  add_modbus_whole(s, "modbus.idle_timeout_ms", &ModbusConfig::idle_timeout_ms, 100, 3600000);
  add_modbus_whole(s, "modbus.command_timeout_ms", &ModbusConfig::command_timeout_ms, 1, 60000);
}

void add_gpio_keys(Setters& s) {
  s["gpio.chip"] = [](PortConfig& c, const std::string& v, const std::string&) { c.gpio.chip = v; };
  s["gpio.consumer"] = [](PortConfig& c, const std::string& v, const std::string& w) {
    if (v.empty()) throw ConfigError(w + ": gpio.consumer must not be empty");
    c.gpio.consumer = v;
  };
  add_gpio_line(s, "gpio.estop_line", &GpioConfig::estop_line, 1023);
  add_gpio_line(s, "gpio.enable_line", &GpioConfig::enable_line, 1023);
  add_gpio_line(s, "gpio.brake_line", &GpioConfig::brake_line, 1023);
  add_gpio_line(s, "gpio.status_line", &GpioConfig::status_line, 1023);
  add_gpio_line(s, "gpio.estop_debounce_ms", &GpioConfig::estop_debounce_ms, 1000);
}

// Joint j's drive: its keys start with p ("joint1.").
void add_joint_keys(Setters& s, unsigned j) {
  const std::string p = "joint" + std::to_string(j + 1) + ".";
  add_joint_number(s, j, p + "gear_ratio", &delta::DriveModel::gear_ratio,
                   {0.0, 4000.0, "", false});
  add_joint_number(s, j, p + "rated_current_A", &delta::DriveModel::rated_current_A,
                   {0.0, 1000.0, " A", false}, &JointDrive::rated_current_set);
  add_joint_number(s, j, p + "rated_torque_Nm", &delta::DriveModel::rated_torque_Nm,
                   {0.0, 10000.0, " N m", false}, &JointDrive::rated_torque_set);
  add_joint_number(s, j, p + "gearbox_efficiency", &delta::DriveModel::gearbox_efficiency,
                   {0.0, 1.0, "", false});
  add_joint_number(s, j, p + "zero_rad", &delta::DriveModel::joint_zero_rad,
                   {-std::numbers::pi, std::numbers::pi, " rad", true});
  s[p + "node"] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    c.joints[j].node = static_cast<std::uint8_t>(parse_unsigned(v, w, p + "node", 1, 127));
  };
  s[p + "counts_per_rev"] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    c.joints[j].model.counts_per_rev = parse_unsigned(v, w, p + "counts_per_rev", 4, 1u << 30);
    c.joints[j].counts_per_rev_set = true;
  };
  s[p + "inverted"] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    c.joints[j].model.inverted = parse_bool(v, w, p + "inverted");
  };
  s[p + "torque_offset_Nm"] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    c.joints[j].torque_offset_Nm = parse_number(v, w, p + "torque_offset_Nm");
  };
  s[p + "eds"] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    read_joint_eds(c, j, p, v, w);
  };
  s[p + "torque_unit"] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    c.joints[j].torque_unit = parse_torque_unit(v, w, p);
    c.joints[j].torque_unit_set = true;
  };
  s[p + "serial"] = [=](PortConfig& c, const std::string& v, const std::string& w) {
    c.joints[j].identity.serial = parse_unsigned(v, w, p + "serial", 0, 0xFFFFFFFFu);
  };
}

Setters make_setters() {
  Setters s;
  add_cycle_keys(s);
  add_motion_keys(s);
  add_run_keys(s);
  add_modbus_keys(s);
  add_gpio_keys(s);
  for (unsigned j = 0; j < 3; ++j) add_joint_keys(s, j);
  return s;
}
}  // namespace

const std::map<std::string, ConfigSetter>& config_setters() {
  static const std::map<std::string, ConfigSetter> s = make_setters();
  return s;
}

}  // namespace fw_linux
