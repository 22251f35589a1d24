// delta_fw's `robot = FILE`: the robot is described once
// (docs/robot-description.md) and the controller takes from it what it
// needs: the geometry, each joint's gear ratio, the limits the file gives
// (limits.*, gains.max_torque_Nm) and, in feed_forward_config, the nominal
// feed-forward. A key the configuration sets as well must agree with it.
#include <cmath>
#include <sstream>

#include "fw_linux/config.hpp"

namespace fw_linux {

namespace {

// A value the description gives: the controller's key, the file's key.
struct Adopted {
  std::string key;
  std::string file_key;
  double* field;
  std::optional<double> value;
};

std::vector<Adopted> adopted(PortConfig& c) {
  const delta::RobotDescription& r = *c.robot;
  delta::Geometry& g = c.geometry;
  std::vector<Adopted> a{
      {"geometry.upper_arm_length_m", "geometry.upper_arm_length_m", &g.upper_arm_length_m,
       r.geometry.upper_arm_length_m},
      {"geometry.forearm_length_m", "geometry.forearm_length_m", &g.forearm_length_m,
       r.geometry.forearm_length_m},
      {"geometry.base_radius_m", "geometry.base_radius_m", &g.base_radius_m,
       r.geometry.base_radius_m},
      {"geometry.platform_radius_m", "geometry.platform_radius_m", &g.platform_radius_m,
       r.geometry.platform_radius_m},
      {"limits.min_rad", "limits.min_rad", &c.min_rad, r.limits.min_rad},
      {"limits.max_rad", "limits.max_rad", &c.max_rad, r.limits.max_rad},
      {"limits.max_velocity_rad_s", "limits.max_velocity_rad_s", &c.max_velocity_rad_s,
       r.limits.max_velocity_rad_s},
      {"limits.max_acceleration_rad_s2", "limits.max_acceleration_rad_s2",
       &c.max_acceleration_rad_s2, r.limits.max_acceleration_rad_s2},
      {"gains.max_torque_Nm", "limits.max_torque_Nm", &c.max_torque_Nm, r.limits.max_torque_Nm}};
  for (unsigned j = 0; j < 3; ++j) {
    a.push_back({"joint" + std::to_string(j + 1) + ".gear_ratio",
                 "joints[" + std::to_string(j) + "].gear_ratio", &c.joints[j].model.gear_ratio,
                 r.joints[j].gear_ratio});
  }
  return a;
}

std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

}  // namespace

void adopt_robot(PortConfig& c, std::vector<std::string>& problems) {
  if (!c.robot) return;
  for (const Adopted& a : adopted(c)) {
    if (!a.value) continue;
    const auto set = c.set_where.find(a.key);
    if (set == c.set_where.end()) {
      *a.field = *a.value;
      continue;
    }
    if (std::abs(*a.field - *a.value) <= 1e-9 * std::max(1.0, std::abs(*a.value))) continue;
    problems.push_back(set->second + ": " + a.key + " = " + number_text(*a.field) +
                       ", but the robot description " + c.robot_file + " (" +
                       c.set_where.at("robot") + ") has " + a.file_key + " = " +
                       number_text(*a.value) +
                       ": give it in one place, the robot description (docs/robot-description.md)");
  }
}

std::string describe_robot(const PortConfig& c) {
  if (!c.robot) return "";
  const delta::Geometry& g = c.geometry;
  std::string text = "robot: " + c.robot_file + " (" + c.robot->name + "): arms " +
                     number_text(g.upper_arm_length_m) + " and " + number_text(g.forearm_length_m) +
                     " m, radii " + number_text(g.base_radius_m) + " and " +
                     number_text(g.platform_radius_m) + " m, gear ratios ";
  for (unsigned j = 0; j < 3; ++j) {
    text += (j == 0 ? "" : ", ") + number_text(c.joints[j].model.gear_ratio);
  }
  text += "; joint range [" + number_text(c.min_rad) + ", " + number_text(c.max_rad) +
          "] rad, at most " + number_text(c.max_velocity_rad_s) + " rad/s, " +
          number_text(c.max_acceleration_rad_s2) + " rad/s^2, " + number_text(c.max_torque_Nm) +
          " N m";
  return text;
}

}  // namespace fw_linux
