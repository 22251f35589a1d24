#include "delta/parameter_file.hpp"

#include <nlohmann/json.hpp>

#include "delta/input_error.hpp"
#include "delta/json_text.hpp"
#include "delta/read_file.hpp"

namespace delta {

LumpedParameters read_lumped_parameters(const std::string& path) {
  LumpedParameters p = default_lumped_parameters();
  nlohmann::json j = parse_json(read_whole_file(path), path);
  if (j.contains("parameters")) j = j["parameters"];  // a saved fit result
  if (!j.is_object()) throw InputError(path + ": expected a JSON object of parameters");
  const auto get = [&](const std::string& key, double& target) {
    if (!j.contains(key)) return;
    if (!j[key].is_number()) throw InputError(path + ": parameter '" + key + "' must be a number");
    target = j[key].get<double>();
  };
  const char* suffix[3] = {"_1", "_2", "_3"};
  for (unsigned i = 0; i < 3; ++i) {
    get("arm_inertia", p.arm_inertia_kg_m2[i]);
    get("arm_gravity_moment", p.arm_gravity_moment_Nm[i]);
    get(std::string("arm_inertia") + suffix[i], p.arm_inertia_kg_m2[i]);
    get(std::string("arm_gravity_moment") + suffix[i], p.arm_gravity_moment_Nm[i]);
    get(std::string("viscous_friction") + suffix[i], p.viscous_friction_Nm_s_per_rad[i]);
    get(std::string("coulomb_friction") + suffix[i], p.coulomb_friction_Nm[i]);
    get(std::string("torque_offset") + suffix[i], p.torque_offset_Nm[i]);
  }
  get("platform_mass", p.platform_mass_kg);
  get("gravity_m_s2", p.gravity_m_s2);
  for (const auto& [key, value] : j.items()) {
    (void)value;
    static const char* known[] = {"arm_inertia", "arm_gravity_moment", "platform_mass",
                                  "gravity_m_s2"};
    bool ok = false;
    for (const char* k : known) ok = ok || key == k;
    for (const char* base : {"arm_inertia", "arm_gravity_moment", "viscous_friction",
                             "coulomb_friction", "torque_offset"}) {
      for (const char* s : suffix) ok = ok || key == std::string(base) + s;
    }
    if (!ok && (key.rfind("arm_gravity_cos", 0) == 0 || key.rfind("platform_inertial", 0) == 0 ||
                key == "forearm_coupling")) {
      throw InputError(path + ": parameter '" + key +
                       "' is the higher-fidelity model's; the lumped plant takes the lumped "
                       "model's parameters (host_id fit --model lumped)");
    }
    if (!ok) throw InputError(path + ": unknown parameter '" + key + "'");
  }
  return p;
}

}  // namespace delta
