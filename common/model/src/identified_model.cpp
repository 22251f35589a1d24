#include "delta/identified_model.hpp"

#include <cmath>
#include <cstdio>
#include <span>

#include "delta/input_error.hpp"
#include "delta/json_text.hpp"
#include "delta/model_terms.hpp"
#include "delta/read_file.hpp"
#include "delta/update/crc32.hpp"

namespace delta {

HighFidelityParameters physical_parameters(
    const std::string& kind, bool per_joint, bool offsets, double coulomb_smoothing_rad_s,
    double stribeck_velocity_rad_s,
    const std::function<std::optional<double>(const std::string& name)>& value) {
  const auto terms = physical_model_terms(kind, stribeck_velocity_rad_s > 0.0, offsets);
  if (terms.empty()) {
    throw InputError("model '" + kind +
                     "' has no physical parameters (only delta and lumped have them)");
  }
  HighFidelityParameters h;
  h.coulomb_smoothing_rad_s = coulomb_smoothing_rad_s;
  h.stribeck_velocity_rad_s = stribeck_velocity_rad_s;
  const auto get = [&](const std::string& name) {
    const auto v = value(name);
    if (!v) throw InputError("parameter '" + name + "' is missing");
    return *v;
  };
  for (const ModelTerm& t : terms) {
    if (t.robot_value != nullptr) {
      const double v = get(t.name);
      h.*(t.robot_value) = v;
      if (t.robot_value_too != nullptr) h.*(t.robot_value_too) = v;
      continue;
    }
    const bool each = term_per_joint(t, per_joint);
    Joint3& joint = h.*(t.joint_value);
    for (unsigned j = 0; j < 3; ++j) {
      joint[j] = each ? get(term_parameter_name(t, true, j)) : (j == 0 ? get(t.name) : joint[0]);
    }
  }
  return h;
}

namespace {

const nlohmann::json& member(const nlohmann::json& parent, const char* key,
                             const std::string& where) {
  if (!parent.is_object() || !parent.contains(key)) {
    throw InputError(where + ": missing key '" + key + "'");
  }
  return parent[key];
}

std::optional<Geometry> geometry_of(const nlohmann::json& j, const std::string& path) {
  if (!j.contains("geometry")) return std::nullopt;
  const auto& g = j["geometry"];
  const auto length = [&](const char* key) {
    const auto& v = member(g, key, path + ": geometry");
    if (!v.is_number()) throw InputError(path + ": geometry." + key + " must be a number");
    return v.get<double>();
  };
  return Geometry{length("upper_arm_length_m"), length("forearm_length_m"), length("base_radius_m"),
                  length("platform_radius_m")};
}

// The collision thresholds where the result has them: three numbers, not
// negative, for each of the three terms.
std::optional<CollisionThresholds> collision_thresholds_of(const nlohmann::json& j,
                                                           const std::string& path) {
  if (!j.contains("collision_thresholds") || j["collision_thresholds"].is_null()) {
    return std::nullopt;
  }
  const auto& c = j["collision_thresholds"];
  const auto joint3 = [&](const char* key) {
    const auto& v = member(c, key, path + ": collision_thresholds");
    Joint3 out{};
    if (!v.is_array() || v.size() != 3) {
      throw InputError(path + ": collision_thresholds." + key + " must be three numbers");
    }
    for (unsigned i = 0; i < 3; ++i) {
      if (!v[i].is_number() || !(v[i].get<double>() >= 0.0)) {
        throw InputError(path + ": collision_thresholds." + key +
                         " must be three numbers, none negative");
      }
      out[i] = v[i].get<double>();
    }
    return out;
  };
  return CollisionThresholds{joint3("base_Nm"), joint3("per_speed_Nm_s_per_rad"),
                             joint3("per_acceleration_Nm_s2_per_rad")};
}

// The gearboxes' compliances of an elastic model (model.
// gearbox_compliance_rad_per_Nm: three numbers, none negative); all 0 for a
// rigid one or a result saved before they were.
Joint3 compliance_of(const nlohmann::json& model, const std::string& path) {
  Joint3 c{};
  if (!model.contains("gearbox_compliance_rad_per_Nm")) return c;
  const auto& v = model["gearbox_compliance_rad_per_Nm"];
  if (!v.is_array() || v.size() != 3) {
    throw InputError(path + ": model.gearbox_compliance_rad_per_Nm must be three numbers");
  }
  for (unsigned i = 0; i < 3; ++i) {
    if (!v[i].is_number() || !(v[i].get<double>() >= 0.0)) {
      throw InputError(path +
                       ": model.gearbox_compliance_rad_per_Nm must be three numbers, none "
                       "negative (rad/(N m); 0: rigid)");
    }
    c[i] = v[i].get<double>();
  }
  return c;
}

// Each joint's cogging, periods and amplitude, where the fit has it
// (cogging_sin_j, cogging_cos_j; null counts as 0).
void cogging_of(const nlohmann::json& model, const nlohmann::json& params, IdentifiedModel& m,
                const std::string& path) {
  if (!model.contains("cogging_periods_per_rev")) return;
  const auto& v = model["cogging_periods_per_rev"];
  if (!v.is_array() || v.size() != 3) {
    throw InputError(path + ": model.cogging_periods_per_rev must be three numbers");
  }
  for (unsigned j = 0; j < 3; ++j) {
    if (!v[j].is_number() || !(v[j].get<double>() >= 0.0 && v[j].get<double>() <= 5000.0)) {
      throw InputError(path +
                       ": model.cogging_periods_per_rev must be three numbers from 0 (none) to "
                       "5000 periods per joint revolution");
    }
    m.cogging_periods_per_rev[j] = v[j].get<double>();
    if (m.cogging_periods_per_rev[j] == 0.0) continue;
    double a[2]{};
    for (unsigned k = 0; k < 2; ++k) {
      const std::string name =
          std::string(k == 0 ? "cogging_sin_" : "cogging_cos_") + std::to_string(j + 1);
      if (!params.is_object() || !params.contains(name)) {
        throw InputError(path + ": parameters." + name + " is missing (the model has cogging)");
      }
      if (params[name].is_number()) {
        a[k] = params[name].get<double>();
      } else if (!params[name].is_null()) {
        throw InputError(path + ": parameters." + name + " must be a number or null");
      }
    }
    m.cogging_amplitude_Nm[j] = std::hypot(a[0], a[1]);
  }
}

// The drive train's terms of a fit that has them (torque_gain_gap_2, _3;
// load_friction_1 to _3); null counts as 0, as for every parameter.
DriveTrainTerms drive_train_of(const nlohmann::json& params, bool gains, bool load,
                               const std::string& path) {
  DriveTrainTerms d;
  const auto get = [&](const std::string& name) {
    if (!params.is_object() || !params.contains(name)) {
      throw InputError(path + ": parameters." + name + " is missing (the model has " +
                       (gains ? "torque gains" : "load friction") + ")");
    }
    const auto& v = params[name];
    if (v.is_null()) return 0.0;
    if (!v.is_number()) throw InputError(path + ": parameters." + name + " must be a number");
    return v.get<double>();
  };
  for (unsigned j = 0; j < 3; ++j) {
    if (gains && j > 0) d.torque_gain_gap[j] = get("torque_gain_gap_" + std::to_string(j + 1));
    if (load) d.load_friction[j] = get("load_friction_" + std::to_string(j + 1));
  }
  return d;
}

}  // namespace

std::string left_out_by_controller(const IdentifiedModel& m) {
  std::string joints;
  for (unsigned j = 0; j < 3; ++j) {
    if (m.cogging_periods_per_rev[j] == 0.0) continue;
    char text[64];
    std::snprintf(text, sizeof text, "%sjoint %u: %.3g N m at %.4g periods per revolution",
                  joints.empty() ? "" : ", ", j + 1, m.cogging_amplitude_Nm[j],
                  m.cogging_periods_per_rev[j]);
    joints += text;
  }
  if (joints.empty()) return "";
  return "the controller's feed-forward leaves out the fit's cogging (" + joints +
         "): it has no cogging term; the collision thresholds were derived without it";
}

IdentifiedModel read_identified_model(const std::string& path) {
  const std::string text = read_whole_file(path);
  const nlohmann::json j = parse_json(text, path);
  if (!j.is_object() || !j.contains("format") || j["format"] != "host_id-result/1") {
    throw InputError(path +
                     ": not a host_id result (expected \"format\": \"host_id-result/1\"); "
                     "save one with host_id fit LOG.csv --out RESULT.json");
  }
  IdentifiedModel m;
  m.fit_id =
      update::crc32(std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
  try {
    const auto& model = member(j, "model", path);
    m.kind = member(model, "name", path + ": model").get<std::string>();
    m.per_joint = member(model, "per_joint", path + ": model").get<bool>();
    m.offsets = member(model, "offsets", path + ": model").get<bool>();
    const double smoothing =
        member(model, "coulomb_smoothing_rad_s", path + ": model").get<double>();
    const double stribeck = model.value("stribeck_velocity_rad_s", 0.0);
    const bool gains = model.value("torque_gains", false);
    const bool load = model.value("load_friction", false);
    m.geometry = geometry_of(j, path);
    m.gearbox_compliance_rad_per_Nm = compliance_of(model, path);
    m.collision_thresholds = collision_thresholds_of(j, path);
    const auto& params = member(j, "parameters", path);
    if (m.kind != "delta" && m.kind != "lumped") {
      throw InputError(path + ": model '" + m.kind +
                       "' has no physical parameters a controller can run; fit with --model "
                       "delta (the default) or lumped");
    }
    m.parameters = physical_parameters(
        m.kind, m.per_joint, m.offsets, smoothing, stribeck,
        [&](const std::string& name) -> std::optional<double> {
          if (!params.is_object() || !params.contains(name)) return std::nullopt;
          const auto& v = params[name];
          if (v.is_null()) return 0.0;
          if (!v.is_number()) {
            throw InputError(path + ": parameters." + name + " must be a number or null");
          }
          return v.get<double>();
        });
    m.drive_train = drive_train_of(params, gains, load, path);
    cogging_of(model, params, m, path);
  } catch (const nlohmann::json::type_error& e) {
    throw InputError(path + ": a model value has the wrong type: " + e.what());
  } catch (const InputError& e) {
    const std::string what = e.what();
    if (what.rfind(path, 0) == 0) throw;
    throw InputError(path + ": " + what);
  }
  return m;
}

}  // namespace delta
