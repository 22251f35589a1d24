#include "host_id/geometry_check.hpp"

#include <cmath>
#include <ostream>
#include <sstream>

#include "delta/input_error.hpp"

namespace host_id {

std::string geometry_text(const delta::Geometry& g) {
  std::ostringstream s;
  s << "upper arm " << g.upper_arm_length_m << " m, forearm " << g.forearm_length_m << " m, base "
    << g.base_radius_m << " m, platform " << g.platform_radius_m << " m";
  return s.str();
}

bool same_geometry(const delta::Geometry& a, const delta::Geometry& b) {
  const auto same = [](double x, double y) {
    return std::abs(x - y) <= 1e-9 * std::max(std::abs(x), std::abs(y));
  };
  return same(a.upper_arm_length_m, b.upper_arm_length_m) &&
         same(a.forearm_length_m, b.forearm_length_m) && same(a.base_radius_m, b.base_radius_m) &&
         same(a.platform_radius_m, b.platform_radius_m);
}

void check_geometry(const std::string& what, const delta::Geometry& found, const std::string& whose,
                    const delta::Geometry& expected, bool allowed, std::ostream& err) {
  if (same_geometry(found, expected)) return;
  const std::string text = what + " is of another robot (" + geometry_text(found) + ") than " +
                           whose + " (" + geometry_text(expected) + ")";
  if (allowed) {
    err << "host_id: warning: " << text << "; going on as --allow-other-geometry asks\n";
    return;
  }
  throw delta::InputError(text +
                          ": parameters do not carry over to another geometry "
                          "(--allow-other-geometry to go on anyway)");
}

void check_result_geometry(const std::string& log_path, const delta::Geometry& log_geometry,
                           const std::string& result, const std::optional<delta::Geometry>& fitted,
                           bool allowed, std::ostream& err) {
  if (fitted) {
    check_geometry(log_path, log_geometry, result + " was fitted for", *fitted, allowed, err);
    return;
  }
  err << result << ": warning: the result has no geometry (saved by an older host_id): " << log_path
      << "'s robot (" << geometry_text(log_geometry)
      << ") cannot be checked against the one it was fitted for; fit again to record it\n";
}

}  // namespace host_id
