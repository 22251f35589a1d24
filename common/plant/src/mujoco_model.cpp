// The MJCF text of a robot description (see delta/mujoco_plant.hpp).
#include "mujoco_model.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "delta/kinematics.hpp"
#include "delta/mujoco_plant.hpp"

namespace delta {

namespace {

// Inertias below this floor are raised to it: a rod whose mass is all in
// its end cups has no inertia about its own axis, but that spin is free and
// decoupled from everything else, and MuJoCo needs it positive.
constexpr double kInertiaFloor_kg_m2 = 1e-9;

std::string numbers(std::initializer_list<double> v) {
  std::ostringstream s;
  s.precision(17);
  bool first = true;
  for (double x : v) {
    s << (first ? "" : " ") << x;
    first = false;
  }
  return s.str();
}

// Each forearm rod as one body: tube and cups, its centre of mass and its
// inertia about it (x along the rod from the elbow).
struct RodInertial {
  double mass_kg{}, com_x_m{}, axial_kg_m2{}, across_kg_m2{};
};

RodInertial rod_inertial(const ForearmRod& rod, double length_m) {
  const double mt = rod.tube_mass_kg, me = rod.elbow_cup_mass_kg, mp = rod.platform_cup_mass_kg;
  const double b = length_m, r = rod.tube_radius_m;
  RodInertial ri;
  ri.mass_kg = mt + me + mp;
  ri.com_x_m = (mt * b / 2.0 + mp * b) / ri.mass_kg;
  const double x = ri.com_x_m;
  ri.across_kg_m2 = mt * (r * r / 2.0 + b * b / 12.0) + mt * (b / 2.0 - x) * (b / 2.0 - x) +
                    me * x * x + mp * (b - x) * (b - x);
  ri.axial_kg_m2 = mt * r * r;
  ri.across_kg_m2 = std::max(ri.across_kg_m2, kInertiaFloor_kg_m2);
  ri.axial_kg_m2 = std::max(ri.axial_kg_m2, kInertiaFloor_kg_m2);
  return ri;
}

void write_options(std::ostream& x, const RobotDescription& d, const MujocoSettings& settings) {
  x << "  <compiler angle=\"radian\" inertiafromgeom=\"false\"/>\n"
    << "  <option timestep=\"" << numbers({settings.max_step_s}) << "\" gravity=\""
    << numbers({0.0, 0.0, -d.gravity_m_s2}) << "\" integrator=\""
    << (settings.integrator == MujocoIntegrator::kRk4 ? "RK4" : "Euler")
    << "\" solver=\"Newton\" iterations=\"100\" tolerance=\"1e-10\""
    << " jacobian=\"dense\">\n"
    << "    <flag contact=\"disable\"/>\n"
    << "  </option>\n";
}

void write_arm(std::ostream& x, const RobotDescription& d, int chain, const Vec3<double>& rod_dir) {
  const auto c = static_cast<unsigned>(chain);
  const double cp = kChainCos[c], sp = kChainSin[c];
  const double r = d.geometry.base_radius_m, a = d.geometry.upper_arm_length_m;
  const UpperArmBody& arm = d.arm(c);
  const InertiaTensor& it = arm.inertia;
  const RodInertial rod = rod_inertial(d.rod, d.geometry.forearm_length_m);
  const std::string n = std::to_string(chain + 1);
  // Arm frame: x radial out, y = z x x (the motor axis), z up.
  x << "    <body name=\"arm" << n << "\" pos=\"" << numbers({r * cp, r * sp, 0.0})
    << "\" xyaxes=\"" << numbers({cp, sp, 0.0, -sp, cp, 0.0}) << "\">\n"
    << "      <joint name=\"theta" << n << "\" type=\"hinge\" axis=\"0 1 0\" armature=\""
    << numbers({d.joints[c].armature_kg_m2()}) << "\"/>\n"
    << "      <inertial pos=\"" << numbers({arm.com_m.x, arm.com_m.y, arm.com_m.z}) << "\" mass=\""
    << numbers({arm.mass_kg}) << "\" fullinertia=\""
    << numbers({it.xx_kg_m2, it.yy_kg_m2, it.zz_kg_m2, it.xy_kg_m2, it.xz_kg_m2, it.yz_kg_m2})
    << "\"/>\n";
  for (const char side : {'a', 'b'}) {
    const double y = (side == 'a' ? 0.5 : -0.5) * d.rod_spacing_m;
    x << "      <body name=\"rod" << n << side << "\" pos=\"" << numbers({a, y, 0.0})
      << "\" xyaxes=\"" << numbers({rod_dir.x, rod_dir.y, rod_dir.z, 0.0, 1.0, 0.0}) << "\">\n"
      << "        <joint name=\"ball" << n << side << "\" type=\"ball\"/>\n"
      << "        <inertial pos=\"" << numbers({rod.com_x_m, 0.0, 0.0}) << "\" mass=\""
      << numbers({rod.mass_kg}) << "\" diaginertia=\""
      << numbers({rod.axial_kg_m2, rod.across_kg_m2, rod.across_kg_m2}) << "\"/>\n"
      << "      </body>\n";
  }
  x << "    </body>\n";
}

void write_platform(std::ostream& x, const RobotDescription& d, const Vec3<double>& home) {
  const double m = d.platform.mass_kg + d.payload.mass_kg;
  const Vec3<double> com =
      (d.platform.com_m * d.platform.mass_kg + d.payload.com_m * d.payload.mass_kg) * (1.0 / m);
  // It only translates; a disc's inertia keeps its (constrained) rotation
  // well conditioned.
  const double rp = std::max(d.geometry.platform_radius_m, 0.01);
  const double i_flat = std::max(m * rp * rp / 4.0, kInertiaFloor_kg_m2);
  x << "    <body name=\"platform\" pos=\"" << numbers({home.x, home.y, home.z}) << "\">\n"
    << "      <freejoint name=\"platform\"/>\n"
    << "      <inertial pos=\"" << numbers({com.x, com.y, com.z}) << "\" mass=\"" << numbers({m})
    << "\" diaginertia=\"" << numbers({i_flat, i_flat, 2.0 * i_flat}) << "\"/>\n"
    << "    </body>\n";
}

}  // namespace

Vec3<double> home_platform_position(const RobotDescription& d) {
  return forward_kinematics(d.geometry, Joint3{0.0, 0.0, 0.0}).position_m;
}

Vec3<double> rod_home_direction(const RobotDescription& d) {
  // At home every chain looks the same in its arm frame (x radial, z up).
  const Vec3<double> p = home_platform_position(d);
  const double b = d.geometry.forearm_length_m;
  const double radial =
      d.geometry.platform_radius_m - d.geometry.base_radius_m - d.geometry.upper_arm_length_m;
  return {radial / b, 0.0, p.z / b};
}

std::string mujoco_model_xml(const RobotDescription& d, const MujocoSettings& settings) {
  std::ostringstream x;
  x << "<mujoco model=\"" << d.name << "\">\n";
  write_options(x, d, settings);
  x << "  <worldbody>\n";
  const Vec3<double> rod_dir = rod_home_direction(d);
  for (int chain = 0; chain < 3; ++chain) write_arm(x, d, chain, rod_dir);
  write_platform(x, d, home_platform_position(d));
  x << "  </worldbody>\n  <equality>\n";
  const double b = d.geometry.forearm_length_m;
  for (int chain = 1; chain <= 3; ++chain) {
    for (const char side : {'a', 'b'}) {
      x << "    <connect body1=\"rod" << chain << side << "\" body2=\"platform\" anchor=\""
        << numbers({b, 0.0, 0.0}) << "\" solref=\"" << numbers({2.0 * settings.max_step_s})
        << " 1\" solimp=\"0.9999 0.9999 0.001 0.5 2\"/>\n";
    }
  }
  x << "  </equality>\n</mujoco>\n";
  return x.str();
}

}  // namespace delta
