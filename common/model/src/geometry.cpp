#include "delta/geometry.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace delta {

GeometryFault check_geometry(const Geometry& g) {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  if (!positive(g.upper_arm_length_m)) return GeometryFault::kUpperArmNotPositive;
  if (!positive(g.forearm_length_m)) return GeometryFault::kForearmNotPositive;
  if (!positive(g.base_radius_m)) return GeometryFault::kBaseRadiusNotPositive;
  if (!std::isfinite(g.platform_radius_m) || g.platform_radius_m < 0.0) {
    return GeometryFault::kPlatformRadiusNegative;
  }
  if (g.upper_arm_length_m + g.forearm_length_m <=
      std::abs(g.base_radius_m - g.platform_radius_m)) {
    return GeometryFault::kCannotAssemble;
  }
  return GeometryFault::kOk;
}

std::string describe_geometry_fault(const Geometry& g) {
  std::ostringstream s;
  switch (check_geometry(g)) {
    case GeometryFault::kOk:
      return {};
    case GeometryFault::kUpperArmNotPositive:
      s << "upper_arm_length_m must be a positive length, got " << g.upper_arm_length_m;
      break;
    case GeometryFault::kForearmNotPositive:
      s << "forearm_length_m must be a positive length, got " << g.forearm_length_m;
      break;
    case GeometryFault::kBaseRadiusNotPositive:
      s << "base_radius_m must be a positive length, got " << g.base_radius_m;
      break;
    case GeometryFault::kPlatformRadiusNegative:
      s << "platform_radius_m must be zero or a positive length, got " << g.platform_radius_m;
      break;
    case GeometryFault::kCannotAssemble:
      s << "the mechanism cannot be assembled: upper_arm_length_m + forearm_length_m ("
        << g.upper_arm_length_m + g.forearm_length_m
        << ") must exceed |base_radius_m - platform_radius_m| ("
        << std::abs(g.base_radius_m - g.platform_radius_m) << ")";
      break;
  }
  return s.str();
}

void require_valid_geometry(const Geometry& g) {
  if (check_geometry(g) != GeometryFault::kOk) {
    throw std::invalid_argument("invalid geometry: " + describe_geometry_fault(g));
  }
}

}  // namespace delta
