#include "delta/model_q.hpp"

#include <cmath>
#include <cstdio>

#include "delta/q_conversion.hpp"

namespace delta {

namespace {

// The largest magnitude a Q format holds (one step below its range).
template <class Q>
double range_of() {
  return std::ldexp(1.0, Q::kIntBits);
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

struct Check {
  std::vector<std::string>& problems;
  template <class Q>
  void value(const std::string& name, double v, bool nonnegative, const char* unit) {
    const double limit = range_of<Q>();
    if (!std::isfinite(v) || std::abs(v) >= limit || (nonnegative && v < 0.0)) {
      problems.push_back("parameter " + name + " = " + number(v) + " " + unit +
                         " is outside what the controller holds: " +
                         (nonnegative ? std::string("0") : number(-limit)) + " to " +
                         number(limit) + " " + unit);
    }
  }
  template <class Q>
  void joints(const std::string& name, const Joint3& v, bool nonnegative, const char* unit) {
    for (unsigned j = 0; j < 3; ++j) {
      value<Q>(name + "_" + std::to_string(j + 1), v[j], nonnegative, unit);
    }
  }
};

// The drive train's terms within what the controller runs (as the record
// checks them): |gap| < 1/2, load friction in [0, 1/2).
void drive_train_problems(const DriveTrainTerms& d, std::vector<std::string>& problems) {
  for (unsigned j = 0; j < 3; ++j) {
    const double gap = d.torque_gain_gap[j];
    const double mu = d.load_friction[j];
    if (!(gap > -0.5 && gap < 0.5)) {
      problems.push_back("parameter torque_gain_gap_" + std::to_string(j + 1) + " = " +
                         number(gap) +
                         " is outside what the controller runs: -0.5 to 0.5 (a torque constant "
                         "that far from joint 1's: check the drives' scaling)");
    }
    if (!(mu >= 0.0 && mu < 0.5)) {
      problems.push_back("parameter load_friction_" + std::to_string(j + 1) + " = " + number(mu) +
                         " is outside what the controller runs: 0 to 0.5");
    }
  }
}

// The gearboxes' compliances within what the record holds: [0, 1/64).
void compliance_problems(const Joint3& compliance, std::vector<std::string>& problems) {
  for (unsigned j = 0; j < 3; ++j) {
    if (!(compliance[j] >= 0.0 && compliance[j] < 1.0 / 64.0)) {
      problems.push_back("model.gearbox_compliance_rad_per_Nm[" + std::to_string(j) +
                         "] = " + number(compliance[j]) +
                         " rad/(N m) is outside what the controller runs: 0 (rigid) to 1/64 "
                         "(a stiffness of 64 N m/rad)");
    }
  }
}

}  // namespace

fx::GeometryQ geometry_q(const Geometry& g) {
  return {to_q_saturated<fx::Q7_24>(g.upper_arm_length_m),
          to_q_saturated<fx::Q7_24>(g.forearm_length_m), to_q_saturated<fx::Q7_24>(g.base_radius_m),
          to_q_saturated<fx::Q7_24>(g.platform_radius_m)};
}

controller::ModelRecord model_record(const IdentifiedModel& m) {
  controller::ModelRecord r;
  r.geometry = geometry_q(m.geometry.value_or(Geometry{}));
  r.parameters = model_parameters_q(m);
  r.fit_id = m.fit_id;
  if (m.collision_thresholds) {
    r.has_collision_thresholds = true;
    r.collision_thresholds = collision_thresholds_q(*m.collision_thresholds);
  }
  return r;
}

fx::CollisionThresholdsQ collision_thresholds_q(const CollisionThresholds& t) {
  fx::CollisionThresholdsQ q;
  for (unsigned j = 0; j < 3; ++j) {
    q.base_Nm[j] = to_q_saturated<fx::Q12_19>(t.base_Nm[j]);
    q.per_speed_Nm_s_per_rad[j] = to_q_saturated<fx::Q12_19>(t.per_speed_Nm_s_per_rad[j]);
    q.per_acceleration_Nm_s2_per_rad[j] =
        to_q_saturated<fx::Q12_19>(t.per_acceleration_Nm_s2_per_rad[j]);
  }
  return q;
}

namespace {

template <class Q>
Joint3 from_q3(const std::array<Q, 3>& v) {
  return {to_double(v[0]), to_double(v[1]), to_double(v[2])};
}

}  // namespace

IdentifiedModel identified_model(const controller::ModelRecord& r) {
  IdentifiedModel m;
  const fx::ModelParametersQ& q = r.parameters;
  m.kind = q.kind == fx::ModelKind::kLumped ? "lumped" : "delta";
  m.fit_id = r.fit_id;
  m.geometry =
      Geometry{to_double(r.geometry.upper_arm_length_m), to_double(r.geometry.forearm_length_m),
               to_double(r.geometry.base_radius_m), to_double(r.geometry.platform_radius_m)};
  HighFidelityParameters& h = m.parameters;
  h.arm_inertia_kg_m2 = from_q3(q.arm_inertia_kg_m2);
  h.arm_gravity_cos_Nm = from_q3(q.arm_gravity_cos_Nm);
  h.arm_gravity_sin_Nm = from_q3(q.arm_gravity_sin_Nm);
  h.platform_inertial_mass_kg = to_double(q.platform_inertial_mass_kg);
  h.platform_weight_mass_kg = to_double(q.platform_weight_mass_kg);
  h.forearm_coupling_kg = to_double(q.forearm_coupling_kg);
  h.viscous_friction_Nm_s_per_rad = from_q3(q.viscous_friction_Nm_s_per_rad);
  h.coulomb_friction_Nm = from_q3(q.coulomb_friction_Nm);
  h.stribeck_friction_Nm = from_q3(q.stribeck_friction_Nm);
  h.torque_offset_Nm = from_q3(q.torque_offset_Nm);
  h.coulomb_smoothing_rad_s = to_double(q.coulomb_smoothing_rad_s);
  h.stribeck_velocity_rad_s = to_double(q.stribeck_velocity_rad_s);
  h.gravity_m_s2 = to_double(q.gravity_m_s2);
  m.per_joint = h.arm_inertia_kg_m2[0] != h.arm_inertia_kg_m2[1] ||
                h.arm_inertia_kg_m2[1] != h.arm_inertia_kg_m2[2];
  m.offsets = h.torque_offset_Nm != Joint3{};
  m.drive_train = DriveTrainTerms{from_q3(q.torque_gain_gap), from_q3(q.load_friction)};
  m.gearbox_compliance_rad_per_Nm = from_q3(q.gearbox_compliance_rad_per_Nm);
  if (r.has_collision_thresholds) {
    const fx::CollisionThresholdsQ& t = r.collision_thresholds;
    m.collision_thresholds =
        CollisionThresholds{from_q3(t.base_Nm), from_q3(t.per_speed_Nm_s_per_rad),
                            from_q3(t.per_acceleration_Nm_s2_per_rad)};
  }
  return m;
}

bool same_geometry(const Geometry& a, const Geometry& b) {
  const auto near = [](double x, double y) { return std::abs(x - y) <= 1e-6; };
  return near(a.upper_arm_length_m, b.upper_arm_length_m) &&
         near(a.forearm_length_m, b.forearm_length_m) && near(a.base_radius_m, b.base_radius_m) &&
         near(a.platform_radius_m, b.platform_radius_m);
}

std::string describe_geometry(const Geometry& g) {
  return "upper arm " + number(g.upper_arm_length_m) + " m, forearm " + number(g.forearm_length_m) +
         " m, base radius " + number(g.base_radius_m) + " m, platform radius " +
         number(g.platform_radius_m) + " m";
}

std::vector<std::string> model_problems(const IdentifiedModel& m, const Geometry& g) {
  std::vector<std::string> problems;
  if (!m.geometry) {
    problems.push_back(
        "the result records no geometry (saved by an older host_id): fit again to save one");
  } else if (!same_geometry(*m.geometry, g)) {
    problems.push_back("fitted for another robot: the model's geometry is " +
                       describe_geometry(*m.geometry) + ", the controller's is " +
                       describe_geometry(g));
  }
  const HighFidelityParameters& p = m.parameters;
  Check c{problems};
  using namespace fx;
  // Named as the result names them (the lumped model's gravity moment and
  // single platform mass).
  const bool lumped = m.kind == "lumped";
  c.joints<Q7_24>("arm_inertia", p.arm_inertia_kg_m2, true, "kg m^2");
  c.joints<Q12_19>(lumped ? "arm_gravity_moment" : "arm_gravity_cos", p.arm_gravity_cos_Nm, true,
                   "N m");
  if (lumped) {
    c.value<Q7_24>("platform_mass", p.platform_weight_mass_kg, true, "kg");
  } else {
    c.joints<Q12_19>("arm_gravity_sin", p.arm_gravity_sin_Nm, false, "N m");
    c.value<Q7_24>("platform_inertial_mass", p.platform_inertial_mass_kg, true, "kg");
    c.value<Q7_24>("platform_weight_mass", p.platform_weight_mass_kg, true, "kg");
    c.value<Q7_24>("forearm_coupling", p.forearm_coupling_kg, true, "kg");
  }
  c.joints<Q12_19>("viscous_friction", p.viscous_friction_Nm_s_per_rad, true, "N m s/rad");
  c.joints<Q12_19>("coulomb_friction", p.coulomb_friction_Nm, true, "N m");
  c.joints<Q12_19>("stribeck_friction", p.stribeck_friction_Nm, true, "N m");
  c.joints<Q12_19>("torque_offset", p.torque_offset_Nm, false, "N m");
  drive_train_problems(m.drive_train, problems);
  compliance_problems(m.gearbox_compliance_rad_per_Nm, problems);
  if (m.collision_thresholds) {
    const CollisionThresholds& t = *m.collision_thresholds;
    c.joints<Q12_19>("collision_thresholds.base", t.base_Nm, true, "N m");
    c.joints<Q12_19>("collision_thresholds.per_speed", t.per_speed_Nm_s_per_rad, true, "N m s/rad");
    c.joints<Q12_19>("collision_thresholds.per_acceleration", t.per_acceleration_Nm_s2_per_rad,
                     true, "N m s^2/rad");
  }
  const double min_speed = std::ldexp(fx::kMinFrictionVelocity.raw(), -21);
  if (!(p.coulomb_smoothing_rad_s >= min_speed && p.coulomb_smoothing_rad_s < 1024.0)) {
    problems.push_back("model.coulomb_smoothing_rad_s = " + number(p.coulomb_smoothing_rad_s) +
                       " rad/s: the controller takes " + number(min_speed) + " to 1024 rad/s");
  }
  if (p.stribeck_velocity_rad_s != 0.0 &&
      !(p.stribeck_velocity_rad_s >= min_speed && p.stribeck_velocity_rad_s < 1024.0)) {
    problems.push_back("model.stribeck_velocity_rad_s = " + number(p.stribeck_velocity_rad_s) +
                       " rad/s: the controller takes 0 (none) or " + number(min_speed) +
                       " to 1024 rad/s");
  }
  return problems;
}

fx::ModelParametersQ model_parameters_q(const IdentifiedModel& m) {
  using namespace fx;
  const HighFidelityParameters& p = m.parameters;
  ModelParametersQ q;
  q.kind = m.kind == "lumped" ? ModelKind::kLumped : ModelKind::kDelta;
  for (unsigned j = 0; j < 3; ++j) {
    q.arm_inertia_kg_m2[j] = to_q_saturated<Q7_24>(p.arm_inertia_kg_m2[j]);
    q.arm_gravity_cos_Nm[j] = to_q_saturated<Q12_19>(p.arm_gravity_cos_Nm[j]);
    q.arm_gravity_sin_Nm[j] = to_q_saturated<Q12_19>(p.arm_gravity_sin_Nm[j]);
    q.viscous_friction_Nm_s_per_rad[j] = to_q_saturated<Q12_19>(p.viscous_friction_Nm_s_per_rad[j]);
    q.coulomb_friction_Nm[j] = to_q_saturated<Q12_19>(p.coulomb_friction_Nm[j]);
    q.stribeck_friction_Nm[j] = to_q_saturated<Q12_19>(p.stribeck_friction_Nm[j]);
    q.torque_offset_Nm[j] = to_q_saturated<Q12_19>(p.torque_offset_Nm[j]);
  }
  q.platform_inertial_mass_kg = to_q_saturated<Q7_24>(p.platform_inertial_mass_kg);
  q.platform_weight_mass_kg = to_q_saturated<Q7_24>(p.platform_weight_mass_kg);
  q.forearm_coupling_kg = to_q_saturated<Q7_24>(p.forearm_coupling_kg);
  q.coulomb_smoothing_rad_s = to_q_saturated<Q10_21>(p.coulomb_smoothing_rad_s);
  q.stribeck_velocity_rad_s = to_q_saturated<Q10_21>(p.stribeck_velocity_rad_s);
  q.gravity_m_s2 = to_q_saturated<Q7_24>(p.gravity_m_s2);
  for (unsigned j = 0; j < 3; ++j) {
    q.torque_gain_gap[j] = to_q_saturated<Q1_30>(m.drive_train.torque_gain_gap[j]);
    q.load_friction[j] = to_q_saturated<Q1_30>(m.drive_train.load_friction[j]);
    q.gearbox_compliance_rad_per_Nm[j] = to_q_saturated<Q1_30>(m.gearbox_compliance_rad_per_Nm[j]);
  }
  return q;
}

}  // namespace delta
