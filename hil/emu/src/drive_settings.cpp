#include "emu/drive_settings.hpp"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <stdexcept>

namespace emu {

namespace {

std::string trimmed(const std::string& s) {
  const auto first = s.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return s.substr(first, s.find_last_not_of(" \t\r") - first + 1);
}

// A number in (0, most] (or [least, most] where least is given), as the
// controller's keys take it (docs/firmware.md).
double number_in(const std::string& v, const std::string& what, double most,
                 std::optional<double> least = std::nullopt) {
  double x = 0;
  const auto r = std::from_chars(v.data(), v.data() + v.size(), x);
  const bool above = least ? x >= *least : x > 0;
  if (r.ec != std::errc() || r.ptr != v.data() + v.size() || !std::isfinite(x) || !above ||
      x > most) {
    char range[64];
    std::snprintf(range, sizeof range, least ? "[%g, %g]" : "(0, %g]", least ? *least : most, most);
    throw std::invalid_argument(what + ": '" + v + "' is not a number in " + range);
  }
  return x;
}

}  // namespace

bool CommissionedDrives::set(const std::string& assignment, const std::string& where) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos) {
    throw std::invalid_argument(where + ": '" + assignment + "' is not KEY=VALUE");
  }
  const std::string key = trimmed(assignment.substr(0, eq));
  const std::string value = trimmed(assignment.substr(eq + 1));
  if (key == "robot") {  // the robot description the controller takes (robot = FILE)
    robot = value;
    taken.push_back(key + "=" + value);
    return true;
  }
  if (key == "approach_s" || key == "stop_s") {  // the arm tracking line's span
    (key == "approach_s" ? approach_s : stop_s) = number_in(value, where + ": " + key, 3600.0);
    taken.push_back(key + "=" + value);
    return true;
  }
  if (key.size() < 8 || key.compare(0, 5, "joint") != 0 || key[6] != '.' || key[5] < '1' ||
      key[5] > '3') {
    return false;  // the controller's
  }
  if (!set_joint(joints[static_cast<unsigned>(key[5] - '1')], key.substr(7), value,
                 where + ": " + key)) {
    return false;  // a controller's joint key (limits, EDS, torque offset): not the drive's
  }
  taken.push_back(key + "=" + value);
  return true;
}

bool CommissionedDrives::set_joint(DriveSettings& d, const std::string& name,
                                   const std::string& value, const std::string& what) {
  if (name == "rated_torque_Nm") {
    d.rated_torque_Nm = number_in(value, what, 10000.0);
  } else if (name == "rated_current_A") {
    d.rated_current_A = number_in(value, what, 1000.0);
  } else if (name == "counts_per_rev") {
    const double c = number_in(value, what, 1073741824.0, 4.0);
    if (c != std::floor(c)) {
      throw std::invalid_argument(what + ": '" + value + "' is not a whole number of counts");
    }
    d.counts_per_rev = static_cast<std::uint32_t>(c);
  } else if (name == "gear_ratio") {
    d.gear_ratio = number_in(value, what, 4000.0);
  } else if (name == "gearbox_efficiency") {
    d.gearbox_efficiency = number_in(value, what, 1.0);
  } else if (name == "inverted") {
    const bool yes = value == "true" || value == "yes" || value == "1";
    if (!yes && value != "false" && value != "no" && value != "0") {
      throw std::invalid_argument(what + ": '" + value + "' is neither true nor false");
    }
    d.inverted = yes;
  } else if (name == "zero_rad") {
    d.zero_rad = number_in(value, what, std::numbers::pi, -std::numbers::pi);
  } else if (name == "torque_unit") {
    if (value != "per_mille" && value != "mA" && value != "mNm") {
      throw std::invalid_argument(what + ": '" + value + "' is not per_mille, mA or mNm");
    }
    if (torque_unit && *torque_unit != value) {
      throw std::invalid_argument(what + ": the emulated drives share one torque unit, and " +
                                  *torque_unit + " was given before");
    }
    torque_unit = value;
  } else {
    return false;
  }
  return true;
}

void CommissionedDrives::read_config(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument(path + ": cannot be read");
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const std::string content = trimmed(line.substr(0, line.find('#')));
    if (content.empty()) continue;
    set(content, path + ":" + std::to_string(n));
  }
}

delta::DriveModel CommissionedDrives::applied(unsigned joint, delta::DriveModel m) const {
  const DriveSettings& d = joints[joint];
  m.rated_torque_Nm = d.rated_torque_Nm.value_or(m.rated_torque_Nm);
  m.rated_current_A = d.rated_current_A.value_or(m.rated_current_A);
  m.counts_per_rev = d.counts_per_rev.value_or(m.counts_per_rev);
  m.gear_ratio = d.gear_ratio.value_or(m.gear_ratio);
  m.gearbox_efficiency = d.gearbox_efficiency.value_or(m.gearbox_efficiency);
  m.inverted = d.inverted.value_or(m.inverted);
  m.joint_zero_rad = d.zero_rad.value_or(m.joint_zero_rad);
  return m;
}

}  // namespace emu
