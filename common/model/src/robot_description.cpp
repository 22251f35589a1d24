#include "delta/robot_description.hpp"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <sstream>

#include "delta/input_error.hpp"
#include "delta/json_text.hpp"
#include "delta/kinematics.hpp"
#include "delta/read_file.hpp"

namespace delta {

namespace {

constexpr const char* kFormat = "delta-robot/1";

std::string number_text(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// A JSON object being read, with the dotted path of its keys for messages
// and the keys it has used, so that unknown ones are named.
class Section {
 public:
  Section(const nlohmann::json& j, std::string file, std::string path)
      : j_(j), file_(std::move(file)), path_(std::move(path)) {
    if (!j_.is_object()) fail(path_.empty() ? "" : path_, "must be a JSON object");
  }

  [[noreturn]] void fail(const std::string& key_path, const std::string& what) const {
    throw InputError(file_ + ": " + (key_path.empty() ? "" : key_path + ": ") + what);
  }
  std::string key_path(const std::string& key) const {
    return path_.empty() ? key : path_ + "." + key;
  }
  bool has(const std::string& key) const { return j_.contains(key); }
  const std::string& file() const { return file_; }

  const nlohmann::json& at(const std::string& key) {
    used_.insert(key);
    if (!j_.contains(key)) fail(key_path(key), "missing");
    return j_.at(key);
  }
  double number(const std::string& key) {
    const nlohmann::json& v = at(key);
    if (!v.is_number()) fail(key_path(key), "must be a number");
    const double d = v.get<double>();
    if (!std::isfinite(d)) fail(key_path(key), "must be finite");
    return d;
  }
  double number_or(const std::string& key, double fallback) {
    return has(key) ? number(key) : (used_.insert(key), fallback);
  }
  Vec3<double> vec3(const std::string& key) {
    const nlohmann::json& v = at(key);
    if (!v.is_array() || v.size() != 3 ||
        !std::all_of(v.begin(), v.end(), [](const auto& e) { return e.is_number(); })) {
      fail(key_path(key), "must be an array of three numbers");
    }
    return {v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
  }
  Section section(const std::string& key) { return Section(at(key), file_, key_path(key)); }

  // Every key of the object was read.
  void done() const {
    for (const auto& [key, value] : j_.items()) {
      (void)value;
      if (!used_.count(key)) fail(key_path(key), "unknown key");
    }
  }

 private:
  const nlohmann::json& j_;
  std::string file_;
  std::string path_;
  std::set<std::string> used_;
};

InertiaTensor read_inertia(Section s) {
  InertiaTensor t;
  t.xx_kg_m2 = s.number("xx");
  t.yy_kg_m2 = s.number("yy");
  t.zz_kg_m2 = s.number("zz");
  t.xy_kg_m2 = s.number_or("xy", 0.0);
  t.xz_kg_m2 = s.number_or("xz", 0.0);
  t.yz_kg_m2 = s.number_or("yz", 0.0);
  s.done();
  return t;
}

UpperArmBody read_arm(Section s) {
  UpperArmBody arm;
  arm.mass_kg = s.number("mass_kg");
  arm.com_m = s.vec3("com_m");
  arm.inertia = read_inertia(s.section("inertia_kg_m2"));
  s.done();
  return arm;
}

// "upper_arms": three entries, each an arm body or null (upper_arm's).
void read_arm_bodies(Section& top, RobotDescription& d) {
  if (!top.has("upper_arms")) return;
  const nlohmann::json& arms = top.at("upper_arms");
  if (!arms.is_array() || arms.size() != 3) {
    top.fail("upper_arms", "must be an array of three arm bodies (null: upper_arm's)");
  }
  for (std::size_t i = 0; i < 3; ++i) {
    if (arms[i].is_null()) continue;
    d.arm_bodies[i] =
        read_arm(Section(arms[i], top.file(), "upper_arms[" + std::to_string(i) + "]"));
  }
}

PlatformMass read_platform_mass(Section s) {
  PlatformMass m;
  m.mass_kg = s.number("mass_kg");
  m.com_m = s.vec3("com_m");
  s.done();
  return m;
}

JointDrive read_joint(Section s) {
  JointDrive j;
  j.rotor_inertia_kg_m2 = s.number("rotor_inertia_kg_m2");
  j.gear_ratio = s.number("gear_ratio");
  j.viscous_friction_Nm_s_per_rad = s.number("viscous_friction_Nm_s_per_rad");
  j.coulomb_friction_Nm = s.number("coulomb_friction_Nm");
  j.friction_smoothing_rad_s = s.number("friction_smoothing_rad_s");
  j.stribeck_friction_Nm = s.number_or("stribeck_friction_Nm", 0.0);
  j.stribeck_velocity_rad_s = s.number_or("stribeck_velocity_rad_s", j.stribeck_velocity_rad_s);
  j.gearbox_stiffness_Nm_per_rad = s.number_or("gearbox_stiffness_Nm_per_rad", 0.0);
  j.gearbox_damping_Nm_s_per_rad = s.number_or("gearbox_damping_Nm_s_per_rad", 0.0);
  j.torque_constant_ratio = s.number_or("torque_constant_ratio", 1.0);
  j.current_filter_time_constant_s = s.number_or("current_filter_time_constant_s", 0.0);
  j.load_friction_coefficient = s.number_or("load_friction_coefficient", 0.0);
  j.cogging_amplitude_Nm = s.number_or("cogging_amplitude_Nm", 0.0);
  j.cogging_periods_per_motor_rev = s.number_or("cogging_periods_per_motor_rev", 0.0);
  s.done();
  return j;
}

void read_geometry(Section s, RobotDescription& d) {
  d.geometry.upper_arm_length_m = s.number("upper_arm_length_m");
  d.geometry.forearm_length_m = s.number("forearm_length_m");
  d.geometry.base_radius_m = s.number("base_radius_m");
  d.geometry.platform_radius_m = s.number("platform_radius_m");
  d.rod_spacing_m = s.number("rod_spacing_m");
  s.done();
}

// "limits": each key optional.
RobotLimits read_limits(Section s) {
  RobotLimits l;
  const auto optional = [&s](const char* key) {
    return s.has(key) ? std::optional<double>(s.number(key)) : std::nullopt;
  };
  l.min_rad = optional("min_rad");
  l.max_rad = optional("max_rad");
  l.max_velocity_rad_s = optional("max_velocity_rad_s");
  l.max_acceleration_rad_s2 = optional("max_acceleration_rad_s2");
  l.max_torque_Nm = optional("max_torque_Nm");
  s.done();
  return l;
}

void read_joints(Section& top, RobotDescription& d, const std::string& file) {
  const nlohmann::json& j = top.at("joints");
  if (j.is_object()) {  // one drive side for all three joints
    d.joints.fill(read_joint(Section(j, file, "joints")));
  } else if (j.is_array() && j.size() == 3) {
    for (unsigned i = 0; i < 3; ++i) {
      d.joints[i] = read_joint(Section(j[i], file, "joints[" + std::to_string(i) + "]"));
    }
  } else {
    top.fail("joints", "must be one object (for all joints) or an array of three");
  }
}

RobotDescription parse(const nlohmann::json& root, const std::string& file) {
  Section top(root, file, "");
  const nlohmann::json& format = top.at("format");
  if (!format.is_string() || format.get<std::string>() != kFormat) {
    top.fail("format", std::string("must be \"") + kFormat + "\"");
  }
  RobotDescription d;
  if (top.has("name")) {
    if (!top.at("name").is_string()) top.fail("name", "must be a string");
    d.name = top.at("name").get<std::string>();
  }
  d.gravity_m_s2 = top.number("gravity_m_s2");
  read_geometry(top.section("geometry"), d);
  Section arm = top.section("upper_arm");
  d.upper_arm = read_arm(arm);
  read_arm_bodies(top, d);
  Section rod = top.section("forearm_rod");
  d.rod.tube_mass_kg = rod.number("tube_mass_kg");
  d.rod.tube_radius_m = rod.number("tube_radius_m");
  d.rod.elbow_cup_mass_kg = rod.number("elbow_cup_mass_kg");
  d.rod.platform_cup_mass_kg = rod.number("platform_cup_mass_kg");
  rod.done();
  d.platform = read_platform_mass(top.section("platform"));
  d.payload = top.has("payload") ? read_platform_mass(top.section("payload")) : PlatformMass{};
  read_joints(top, d, file);
  if (top.has("limits")) d.limits = read_limits(top.section("limits"));
  top.done();
  return d;
}

// The eigenvalues of a symmetric 3x3 matrix, ascending (the trigonometric
// solution of its characteristic cubic).
std::array<double, 3> eigenvalues(const InertiaTensor& t) {
  const double a = t.xx_kg_m2, b = t.yy_kg_m2, c = t.zz_kg_m2;
  const double d = t.xy_kg_m2, e = t.xz_kg_m2, f = t.yz_kg_m2;
  const double off = d * d + e * e + f * f;
  const double mean = (a + b + c) / 3.0;
  const double p2 =
      (a - mean) * (a - mean) + (b - mean) * (b - mean) + (c - mean) * (c - mean) + 2.0 * off;
  if (p2 <= 0.0) return {a, b, c};
  const double p = std::sqrt(p2 / 6.0);
  // B = (A - mean I) / p; r = det(B) / 2, clamped to [-1, 1].
  const double ba = (a - mean) / p, bb = (b - mean) / p, bc = (c - mean) / p;
  const double bd = d / p, be = e / p, bf = f / p;
  const double det = ba * (bb * bc - bf * bf) - bd * (bd * bc - bf * be) + be * (bd * bf - bb * be);
  const double r = std::clamp(det / 2.0, -1.0, 1.0);
  const double phi = std::acos(r) / 3.0;
  const double largest = mean + 2.0 * p * std::cos(phi);
  const double smallest = mean + 2.0 * p * std::cos(phi + 2.0 * std::numbers::pi / 3.0);
  return {smallest, 3.0 * mean - largest - smallest, largest};
}

void require_non_negative(const std::string& where, const std::string& key, double v) {
  if (!(v >= 0.0))
    throw InputError(where + ": " + key + ": must not be negative (got " + number_text(v) + ")");
}

void require_positive(const std::string& where, const std::string& key, double v) {
  if (!(v > 0.0))
    throw InputError(where + ": " + key + ": must be positive (got " + number_text(v) + ")");
}

void validate_inertia(const std::string& where, const std::string& key, const InertiaTensor& t) {
  const std::array<double, 3> ev = eigenvalues(t);
  if (!(ev[0] > 0.0)) {
    throw InputError(where + ": " + key + ": not positive definite (smallest principal moment " +
                     number_text(ev[0]) + " kg m^2)");
  }
  // A body's principal moments satisfy I1 + I2 >= I3 (with a little room
  // for rounding in the file's numbers).
  if (ev[0] + ev[1] < ev[2] * (1.0 - 1e-9)) {
    throw InputError(where + ": " + key + ": no body has these principal moments (" +
                     number_text(ev[0]) + " + " + number_text(ev[1]) + " < " + number_text(ev[2]) +
                     " kg m^2)");
  }
}

void validate_joint(const std::string& where, const std::string& key, const JointDrive& j) {
  require_non_negative(where, key + ".rotor_inertia_kg_m2", j.rotor_inertia_kg_m2);
  require_positive(where, key + ".gear_ratio", j.gear_ratio);
  require_non_negative(where, key + ".viscous_friction_Nm_s_per_rad",
                       j.viscous_friction_Nm_s_per_rad);
  require_non_negative(where, key + ".coulomb_friction_Nm", j.coulomb_friction_Nm);
  require_non_negative(where, key + ".stribeck_friction_Nm", j.stribeck_friction_Nm);
  require_positive(where, key + ".stribeck_velocity_rad_s", j.stribeck_velocity_rad_s);
  require_positive(where, key + ".friction_smoothing_rad_s", j.friction_smoothing_rad_s);
  require_non_negative(where, key + ".gearbox_stiffness_Nm_per_rad",
                       j.gearbox_stiffness_Nm_per_rad);
  require_non_negative(where, key + ".gearbox_damping_Nm_s_per_rad",
                       j.gearbox_damping_Nm_s_per_rad);
  if (!j.elastic() && j.gearbox_damping_Nm_s_per_rad > 0.0) {
    throw InputError(where + ": " + key +
                     ".gearbox_damping_Nm_s_per_rad: needs an elastic gearbox "
                     "(gearbox_stiffness_Nm_per_rad above 0)");
  }
  if (j.elastic() && !(j.rotor_inertia_kg_m2 > 0.0)) {
    throw InputError(where + ": " + key +
                     ".rotor_inertia_kg_m2: must be positive with an elastic gearbox (the motor "
                     "side moves on its own)");
  }
  require_positive(where, key + ".torque_constant_ratio", j.torque_constant_ratio);
  require_non_negative(where, key + ".current_filter_time_constant_s",
                       j.current_filter_time_constant_s);
  if (!(j.load_friction_coefficient >= 0.0 && j.load_friction_coefficient < 1.0)) {
    throw InputError(where + ": " + key + ".load_friction_coefficient: must lie in [0, 1) (got " +
                     number_text(j.load_friction_coefficient) + ")");
  }
  require_non_negative(where, key + ".cogging_amplitude_Nm", j.cogging_amplitude_Nm);
  require_non_negative(where, key + ".cogging_periods_per_motor_rev",
                       j.cogging_periods_per_motor_rev);
  if (j.cogging_amplitude_Nm > 0.0 && !(j.cogging_periods_per_motor_rev >= 1.0)) {
    throw InputError(where + ": " + key +
                     ".cogging_periods_per_motor_rev: must be at least 1 with a cogging amplitude");
  }
}

void validate_limits(const std::string& where, const RobotLimits& l) {
  const auto positive = [&where](const char* key, const std::optional<double>& v) {
    if (v) require_positive(where, std::string("limits.") + key, *v);
  };
  positive("max_velocity_rad_s", l.max_velocity_rad_s);
  positive("max_acceleration_rad_s2", l.max_acceleration_rad_s2);
  positive("max_torque_Nm", l.max_torque_Nm);
  if (l.min_rad && l.max_rad && !(*l.min_rad < *l.max_rad)) {
    throw InputError(where + ": limits.min_rad: must be below limits.max_rad (" +
                     number_text(*l.min_rad) + " >= " + number_text(*l.max_rad) + ")");
  }
  for (const auto& [key, v] : {std::pair{"min_rad", l.min_rad}, std::pair{"max_rad", l.max_rad}}) {
    if (v && !(std::abs(*v) < std::numbers::pi)) {
      throw InputError(where + ": limits." + key + ": must lie within (-pi, pi) rad (got " +
                       number_text(*v) + ")");
    }
  }
}

}  // namespace

void validate_robot_description(const RobotDescription& d, const std::string& where) {
  if (check_geometry(d.geometry) != GeometryFault::kOk) {
    throw InputError(where + ": geometry: " + describe_geometry_fault(d.geometry));
  }
  require_positive(where, "geometry.rod_spacing_m", d.rod_spacing_m);
  require_positive(where, "gravity_m_s2", d.gravity_m_s2);
  require_positive(where, "upper_arm.mass_kg", d.upper_arm.mass_kg);
  validate_inertia(where, "upper_arm.inertia_kg_m2", d.upper_arm.inertia);
  for (std::size_t i = 0; i < 3; ++i) {
    if (!d.arm_bodies[i]) continue;
    const std::string key = "upper_arms[" + std::to_string(i) + "]";
    require_positive(where, key + ".mass_kg", d.arm_bodies[i]->mass_kg);
    validate_inertia(where, key + ".inertia_kg_m2", d.arm_bodies[i]->inertia);
  }
  require_non_negative(where, "forearm_rod.tube_mass_kg", d.rod.tube_mass_kg);
  require_non_negative(where, "forearm_rod.tube_radius_m", d.rod.tube_radius_m);
  if (!(d.rod.tube_radius_m < d.geometry.forearm_length_m / 2.0)) {
    throw InputError(where +
                     ": forearm_rod.tube_radius_m: must be less than half the forearm length");
  }
  require_non_negative(where, "forearm_rod.elbow_cup_mass_kg", d.rod.elbow_cup_mass_kg);
  require_non_negative(where, "forearm_rod.platform_cup_mass_kg", d.rod.platform_cup_mass_kg);
  require_positive(where, "forearm_rod (tube and cups together) mass",
                   d.rod.tube_mass_kg + d.rod.elbow_cup_mass_kg + d.rod.platform_cup_mass_kg);
  require_positive(where, "platform.mass_kg", d.platform.mass_kg);
  require_non_negative(where, "payload.mass_kg", d.payload.mass_kg);
  for (unsigned i = 0; i < 3; ++i) {
    validate_joint(where, "joints[" + std::to_string(i) + "]", d.joints[i]);
  }
  const auto elastic = std::count_if(d.joints.begin(), d.joints.end(),
                                     [](const JointDrive& j) { return j.elastic(); });
  if (elastic != 0 && elastic != 3) {
    throw InputError(where +
                     ": joints: gearbox_stiffness_Nm_per_rad: give all three joints an elastic "
                     "gearbox or none (a robot's gearboxes are of one kind)");
  }
  validate_limits(where, d.limits);
  // The model is built in its home pose, all arms horizontal.
  if (forward_kinematics(d.geometry, Joint3{0.0, 0.0, 0.0}).status != KinematicsStatus::kOk) {
    throw InputError(where + ": geometry: the robot cannot be assembled with its arms horizontal");
  }
}

RobotDescription read_robot_description(const std::string& path) {
  const nlohmann::json j = parse_json(read_file_bytes(path).view(), path);
  RobotDescription d = parse(j, path);
  validate_robot_description(d, path);
  return d;
}

RobotDescription default_robot_description() {
  RobotDescription d;
  // A 0.35 kg aluminium arm of 0.2 m with its motor hub: centre of mass
  // 0.1 m out and 10 mm below the arm line.
  d.upper_arm.mass_kg = 0.35;
  d.upper_arm.com_m = {0.1, 0.0, -0.01};
  d.upper_arm.inertia = {2.0e-5, 1.1667e-3, 1.1667e-3, 0.0, 0.0, 0.0};
  // Carbon rods of 40 g with 5 g ball cups at each end.
  d.rod = {0.04, 0.004, 0.005, 0.005};
  d.platform = {0.25, {0.0, 0.0, -0.005}};
  d.payload = {0.0, {0.0, 0.0, -0.02}};
  const std::array<double, 3> viscous{0.020, 0.025, 0.018};
  const std::array<double, 3> coulomb{0.060, 0.050, 0.070};
  for (unsigned i = 0; i < 3; ++i) {
    JointDrive& j = d.joints[i];
    j.rotor_inertia_kg_m2 = 5.0e-6;
    j.gear_ratio = 10.0;
    j.viscous_friction_Nm_s_per_rad = viscous[i];
    j.coulomb_friction_Nm = coulomb[i];
    j.stribeck_friction_Nm = 0.02;
    j.stribeck_velocity_rad_s = 0.1;
    j.friction_smoothing_rad_s = 0.02;
  }
  return d;
}

double joint_friction_Nm(const JointDrive& j, double qd_rad_s) {
  const double v = qd_rad_s / j.stribeck_velocity_rad_s;
  return j.viscous_friction_Nm_s_per_rad * qd_rad_s +
         (j.coulomb_friction_Nm + j.stribeck_friction_Nm * std::exp(-v * v)) *
             std::tanh(qd_rad_s / j.friction_smoothing_rad_s);
}

RodMassSplit rod_mass_split(const ForearmRod& rod, double length_m) {
  // Uniform tube: A = C = m/3, B = m/6. Its tumbling about axes across the
  // rod adds k = m r^2 / (2 b^2) to A and C and takes it from B (thin wall,
  // |v_P - v_E| = b |omega|); the cups are point masses at the ends.
  RodMassSplit s;
  const double m = rod.tube_mass_kg;
  const double b = length_m;
  const double k = m * rod.tube_radius_m * rod.tube_radius_m / (2.0 * b * b);
  s.a_kg = m / 3.0 + k + rod.elbow_cup_mass_kg;
  s.b_kg = m / 6.0 - k;
  s.c_kg = m / 3.0 + k + rod.platform_cup_mass_kg;
  s.elbow_weight_kg = m / 2.0 + rod.elbow_cup_mass_kg;
  s.platform_weight_kg = m / 2.0 + rod.platform_cup_mass_kg;
  return s;
}

namespace {

// The arm's inertia about its motor axis (y of the arm frame).
double arm_axis_inertia(const UpperArmBody& arm) {
  return arm.inertia.yy_kg_m2 +
         arm.mass_kg * (arm.com_m.x * arm.com_m.x + arm.com_m.z * arm.com_m.z);
}

}  // namespace

LumpedParameters lumped_truth(const RobotDescription& d) {
  LumpedParameters p;
  const RodMassSplit s = rod_mass_split(d.rod, d.geometry.forearm_length_m);
  const double a = d.geometry.upper_arm_length_m;
  const double elbow_kg = 2.0 * s.elbow_weight_kg;  // two rods per forearm
  for (unsigned i = 0; i < 3; ++i) {
    p.arm_inertia_kg_m2[i] =
        arm_axis_inertia(d.arm(i)) + d.joints[i].armature_kg_m2() + elbow_kg * a * a;
    p.arm_gravity_moment_Nm[i] =
        d.gravity_m_s2 * (d.arm(i).mass_kg * d.arm(i).com_m.x + elbow_kg * a);
    p.viscous_friction_Nm_s_per_rad[i] = d.joints[i].viscous_friction_Nm_s_per_rad;
    p.coulomb_friction_Nm[i] = d.joints[i].coulomb_friction_Nm;
  }
  p.platform_mass_kg = d.platform.mass_kg + d.payload.mass_kg + 6.0 * s.platform_weight_kg;
  p.gravity_m_s2 = d.gravity_m_s2;
  return p;
}

HighFidelityParameters high_fidelity_truth(const RobotDescription& d) {
  HighFidelityParameters t;
  const RodMassSplit s = rod_mass_split(d.rod, d.geometry.forearm_length_m);
  const double a = d.geometry.upper_arm_length_m;
  const double g = d.gravity_m_s2;
  for (unsigned i = 0; i < 3; ++i) {
    t.arm_inertia_kg_m2[i] =
        arm_axis_inertia(d.arm(i)) + d.joints[i].armature_kg_m2() + 2.0 * s.a_kg * a * a;
    t.arm_gravity_cos_Nm[i] =
        g * (d.arm(i).mass_kg * d.arm(i).com_m.x + 2.0 * s.elbow_weight_kg * a);
    t.arm_gravity_sin_Nm[i] = -g * d.arm(i).mass_kg * d.arm(i).com_m.z;
    t.viscous_friction_Nm_s_per_rad[i] = d.joints[i].viscous_friction_Nm_s_per_rad;
    t.coulomb_friction_Nm[i] = d.joints[i].coulomb_friction_Nm;
    t.stribeck_friction_Nm[i] = d.joints[i].stribeck_friction_Nm;
  }
  // The shape as the model has it: one smoothing and one Stribeck velocity
  // for the three joints (joint 1's).
  t.coulomb_smoothing_rad_s = d.joints[0].friction_smoothing_rad_s;
  t.stribeck_velocity_rad_s = d.joints[0].stribeck_velocity_rad_s;
  const double platform_kg = d.platform.mass_kg + d.payload.mass_kg;
  t.platform_inertial_mass_kg = platform_kg + 6.0 * s.c_kg;
  t.platform_weight_mass_kg = platform_kg + 6.0 * s.platform_weight_kg;
  t.forearm_coupling_kg = 2.0 * s.b_kg;
  t.gravity_m_s2 = g;
  return t;
}

}  // namespace delta
