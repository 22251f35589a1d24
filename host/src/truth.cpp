#include "host_id/truth.hpp"

namespace host_id {

std::map<std::string, double> parameter_truth(const ModelOptions& model,
                                              const delta::RobotDescription& robot) {
  std::map<std::string, double> t;
  if (model.name != "delta") return t;
  const delta::LumpedParameters p = delta::lumped_truth(robot);
  const char* suffix[3] = {"_1", "_2", "_3"};
  double inertia = 0.0, gravity = 0.0;
  for (unsigned j = 0; j < 3; ++j) {
    inertia += p.arm_inertia_kg_m2[j] / 3.0;
    gravity += p.arm_gravity_moment_Nm[j] / 3.0;
    if (model.per_joint) {
      t[std::string("arm_inertia") + suffix[j]] = p.arm_inertia_kg_m2[j];
      t[std::string("arm_gravity_moment") + suffix[j]] = p.arm_gravity_moment_Nm[j];
    }
    t[std::string("viscous_friction") + suffix[j]] = p.viscous_friction_Nm_s_per_rad[j];
    t[std::string("coulomb_friction") + suffix[j]] = p.coulomb_friction_Nm[j];
    if (model.offsets) t[std::string("torque_offset") + suffix[j]] = 0.0;
  }
  if (!model.per_joint) {
    t["arm_inertia"] = inertia;
    t["arm_gravity_moment"] = gravity;
  }
  t["platform_mass"] = p.platform_mass_kg;
  return t;
}

}  // namespace host_id
