// A result saved by host_id fit (host_id-result/1, docs/report.md), read
// back for validate, predict, simulate --params and a payload's base fit.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <string>

#include "delta/input_error.hpp"
#include "delta/json_text.hpp"
#include "delta/read_file.hpp"
#include "host_id/report.hpp"

namespace host_id {

namespace {

using nlohmann::json;

// The result file's keys, each missing one named with its path.
struct ResultFile {
  const std::string& path;
  const json& need(const json& parent, const char* key, const char* where) const {
    if (!parent.is_object() || !parent.contains(key)) {
      throw delta::InputError(path + ": missing key '" + std::string(where) + key + "'");
    }
    return parent[key];
  }
};

// Three numbers from 0 to `most` under model.KEY, or zeros where an older
// result has no key.
delta::Joint3 read_joint3(const ResultFile& f, const json& m, const char* key, double most,
                          const char* what) {
  delta::Joint3 out{};
  if (!m.contains(key)) return out;
  const json& c = m[key];
  const auto bad = [most](const json& v) {
    return !v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0.0 ||
           v.get<double>() > most;
  };
  if (!c.is_array() || c.size() != 3 || std::any_of(c.begin(), c.end(), bad)) {
    throw delta::InputError(f.path + ": model." + key + " must be " + what);
  }
  for (unsigned k = 0; k < 3; ++k) out[k] = c[k].get<double>();
  return out;
}

ModelOptions read_model_options(const ResultFile& f, const json& j) {
  const json& m = f.need(j, "model", "");
  ModelOptions model;
  model.name = f.need(m, "name", "model.").get<std::string>();
  model.per_joint = f.need(m, "per_joint", "model.").get<bool>();
  model.offsets = f.need(m, "offsets", "model.").get<bool>();
  model.coulomb_smoothing_rad_s = f.need(m, "coulomb_smoothing_rad_s", "model.").get<double>();
  // Results saved before the Stribeck term have no key: no term.
  model.stribeck_velocity_rad_s = m.value("stribeck_velocity_rad_s", 0.0);
  // Results saved before the drive train's terms have no keys: none.
  model.load_friction = m.value("load_friction", false);
  model.torque_gains = m.value("torque_gains", false);
  model.gearbox_compliance_rad_per_Nm =
      read_joint3(f, m, "gearbox_compliance_rad_per_Nm", std::numeric_limits<double>::infinity(),
                  "three compliances >= 0 in rad/(N m), one per joint (0: rigid)");
  model.cogging_periods_per_rev =
      read_joint3(f, m, "cogging_periods_per_rev", kMaxCoggingPeriodsPerRev,
                  "three cogging periods per joint revolution, 0 (none) to 5000");
  return model;
}

// Results saved before the geometry was recorded have none.
std::optional<delta::Geometry> read_geometry(const ResultFile& f, const json& j) {
  if (!j.contains("geometry")) return std::nullopt;
  const json& g = j["geometry"];
  return delta::Geometry{f.need(g, "upper_arm_length_m", "geometry.").get<double>(),
                         f.need(g, "forearm_length_m", "geometry.").get<double>(),
                         f.need(g, "base_radius_m", "geometry.").get<double>(),
                         f.need(g, "platform_radius_m", "geometry.").get<double>()};
}

TimeSteps read_time_steps(const ResultFile& f, const std::string& steps) {
  if (steps != "check" && steps != "nominal" && steps != "as-logged") {
    throw delta::InputError(f.path + ": preprocessing.time_steps is '" + steps +
                            "', not check, nominal or as-logged");
  }
  return steps == "nominal"     ? TimeSteps::kNominal
         : steps == "as-logged" ? TimeSteps::kAsLogged
                                : TimeSteps::kCheck;
}

PrepareOptions read_preprocessing(const ResultFile& f, const json& j) {
  const json& pre = f.need(j, "preprocessing", "");
  PrepareOptions prepare;
  prepare.cutoff_hz = f.need(pre, "cutoff_hz", "preprocessing.").get<double>();
  // Results saved before the state filter had its own cut-off filtered q
  // at cutoff_hz.
  const json state = pre.value("state_cutoff_hz", json(prepare.cutoff_hz));
  if (state.is_string()) {
    if (state.get<std::string>() != "auto") {
      throw delta::InputError(f.path + ": preprocessing.state_cutoff_hz is '" +
                              state.get<std::string>() + "', not auto or a number of Hz");
    }
  } else {
    prepare.state_cutoff_hz = state.get<double>();
  }
  prepare.trim_samples = f.need(pre, "trim_samples", "preprocessing.").get<long>();
  if (const auto it = pre.find("time_steps"); it != pre.end()) {
    prepare.time_steps = read_time_steps(f, it->get<std::string>());
  }
  return prepare;
}

// The parameters in the model's order.
Eigen::VectorXd read_parameters(const ResultFile& f, const json& j, const ModelOptions& options) {
  std::unique_ptr<Model> model;
  try {
    model = make_model(options);
  } catch (const delta::InputError& e) {
    throw delta::InputError(f.path + ": model: " + e.what());
  }
  const json& params = f.need(j, "parameters", "");
  if (options.name == "delta" && params.is_object() && params.contains("platform_mass")) {
    throw delta::InputError(f.path +
                            ": model.name is 'delta' but the parameters are the lumped model's "
                            "(platform_mass): a result saved before 'delta' became the "
                            "higher-fidelity model; set model.name to 'lumped'");
  }
  Eigen::VectorXd beta(static_cast<Eigen::Index>(model->size()));
  for (std::size_t i = 0; i < model->size(); ++i) {
    const std::string& name = model->parameters()[i].name;
    const json& v = f.need(params, name.c_str(), "parameters.");
    // null: not identifiable on the fitted log, absorbed by the base
    // parameters, so 0 predicts what the fit did.
    if (!v.is_number() && !v.is_null()) {
      throw delta::InputError(f.path + ": parameters." + name + " must be a number or null");
    }
    beta(static_cast<Eigen::Index>(i)) = v.is_null() ? 0.0 : v.get<double>();
  }
  return beta;
}

// The fitted log's motion, where the result has it.
MotionRanges read_excitation(const ResultFile& f, const json& j) {
  MotionRanges r;
  if (!j.contains("fit") || !j["fit"].is_object() || !j["fit"].contains("ranges")) return r;
  const json& ranges = j["fit"]["ranges"];
  try {
    r.q_min_rad = ranges.at("q_min_rad").get<std::array<double, 3>>();
    r.q_max_rad = ranges.at("q_max_rad").get<std::array<double, 3>>();
    r.qd_max_rad_s = ranges.at("qd_max_rad_s").get<std::array<double, 3>>();
    r.qdd_max_rad_s2 = ranges.at("qdd_max_rad_s2").get<std::array<double, 3>>();
  } catch (const json::exception& e) {
    throw delta::InputError(f.path + ": fit.ranges: " + e.what() +
                            " (four arrays of three numbers: q_min_rad, q_max_rad, qd_max_rad_s, "
                            "qdd_max_rad_s2)");
  }
  r.known = true;
  return r;
}

}  // namespace

SavedResult read_saved_result(const std::string& path) {
  const json j = delta::parse_json(delta::read_whole_file(path), path);
  const ResultFile f{path};
  if (!j.is_object() || f.need(j, "format", "") != "host_id-result/1") {
    throw delta::InputError(path +
                            ": not a host_id result (expected \"format\": \"host_id-result/1\")");
  }
  SavedResult s;
  try {
    s.model = read_model_options(f, j);
    s.geometry = read_geometry(f, j);
    s.prepare = read_preprocessing(f, j);
  } catch (const json::type_error& e) {
    throw delta::InputError(path +
                            ": a model or preprocessing value has the wrong type: " + e.what());
  }
  s.beta = read_parameters(f, j, s.model);
  s.excitation = read_excitation(f, j);
  return s;
}

}  // namespace host_id
