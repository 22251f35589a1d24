// Why a fit cannot be trusted as it stands (identify.hpp, doubts_of;
// docs/trust.md, "DOUBTFUL"): poor excitation, loose or pinned parameters,
// implausible masses, a friction shape at its bound, parameters that
// change along the log, a log that supports another variant.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include "host_id/elasticity.hpp"
#include "host_id/friction_shape.hpp"
#include "host_id/identify.hpp"

namespace host_id {

namespace {

// Masses no delta of this geometry has: the platform's (with its payload)
// over kImplausibleMassKg, or an arm's inertia over that mass at the arm's
// length. Logged torques a thousand times too large (mN m for N m) give
// such values; "" where none is.
std::string implausible_masses(const FitResult& r) {
  constexpr double kImplausibleMassKg = 100.0;
  const double arm_limit =
      kImplausibleMassKg * r.geometry.upper_arm_length_m * r.geometry.upper_arm_length_m;
  std::string found;
  for (const ParameterEstimate& e : r.parameters) {
    const std::string& n = e.info.name;
    const bool mass = n.rfind("platform", 0) == 0 && e.info.unit == "kg";
    const bool inertia = n.rfind("arm_inertia", 0) == 0;
    if ((mass && e.value > kImplausibleMassKg) || (inertia && e.value > arm_limit)) {
      std::ostringstream v;
      v << (found.empty() ? "" : ", ") << n << " = " << std::setprecision(4) << e.value << " "
        << e.info.unit;
      found += v.str();
    }
  }
  if (found.empty()) return "";
  return "the masses are implausible for this robot (" + found + ", with " +
         format_number(r.geometry.upper_arm_length_m) +
         " m arms): a torque logged in mN m instead of N m gives a thousand times the true "
         "values; check the log's torque unit (docs/log-format.md)";
}

// A gearbox stiffness searched from the motor's encoders (--elastic) that
// ended on the search's bound; "" where none did.
std::string stiffness_doubt(const FitResult& r) {
  if (!r.elasticity || r.elasticity->from_arm_encoders) return "";
  std::string joints;
  for (unsigned j = 0; j < 3; ++j) {
    if (r.elasticity->compliance_rad_per_Nm[j] > kComplianceMaxRadPerNm / 1.02) {
      joints += (joints.empty() ? "" : ", ") + std::to_string(j + 1);
    }
  }
  if (joints.empty()) return "";
  return "the gearbox stiffness search ended on its bound (" +
         format_number(1.0 / kComplianceMaxRadPerNm) + " N m/rad) at joint(s) " + joints +
         ": the drive train is softer than the search covers, or the log explains something "
         "else by it; log the arm's encoders (qa1..qa3) or give the stiffness "
         "(--gearbox-stiffness)";
}

// The friction's shape: a search that ended on its bound, or a residual
// with the Stribeck signature the model lacks; "" where neither.
std::string friction_shape_doubt(const FitResult& r) {
  std::ostringstream m;
  if (r.friction_shape) {
    const FrictionShapeResult& f = *r.friction_shape;
    const auto at = [](double v, double lo, double hi) { return v < 1.02 * lo || v > hi / 1.02; };
    const bool smoothing = at(f.coulomb_smoothing_rad_s, kSmoothingMinRadS, kSmoothingMaxRadS);
    const bool stribeck = f.stribeck_velocity_rad_s > 0.0 &&
                          at(f.stribeck_velocity_rad_s, kStribeckMinRadS, kStribeckMaxRadS);
    if (smoothing || stribeck) {
      m << "the friction shape's search ended on its bound ("
        << (smoothing ? "Coulomb smoothing " + format_number(f.coulomb_smoothing_rad_s) +
                            " rad/s, searched in [" + format_number(kSmoothingMinRadS) + ", " +
                            format_number(kSmoothingMaxRadS) + "]"
                      : "Stribeck velocity " + format_number(f.stribeck_velocity_rad_s) +
                            " rad/s, searched in [" + format_number(kStribeckMinRadS) + ", " +
                            format_number(kStribeckMaxRadS) + "]")
        << "): the log does not determine it, and the friction parameters are fitted to a "
           "shape chosen by the bound; give the shape (--coulomb-smoothing, "
           "--stribeck-velocity) or excite slow motion more";
      return m.str();
    }
  }
  if (r.stribeck) {
    m << "the residual has the Stribeck signature: friction that falls off with speed "
      << "(a Stribeck term at " << format_number(r.stribeck->velocity_rad_s)
      << " rad/s) lowers the model's torque error by "
      << std::lround(100.0 * r.stribeck->error_drop)
      << " %; without it the viscous and Coulomb friction are biased. Fit with "
         "--stribeck-velocity "
      << format_number(r.stribeck->velocity_rad_s)
      << " (add --fit-friction-shape to search the velocity)";
  }
  return m.str();
}

// Parameters that change along the log (FitResult::changing); "" where
// none does.
std::string changing_doubt(const FitResult& r) {
  if (r.changing.empty()) return "";
  std::string names;
  for (const std::string& n : r.changing) names += (names.empty() ? "" : ", ") + n;
  std::ostringstream m;
  m << names << " change along the log: their estimates from its thirds in time differ up to "
    << std::lround(r.changing_ratio)
    << " times more than over any split of its motions. Runs of different payloads, robots "
       "or settings glued into one log, or a drift (a loosening part, warming grease), give "
       "this; fit each run alone (a payload: fit --base, docs/payload.md)";
  return m.str();
}

// Another variant of the model that the log supports better than the one
// fitted (FitResult::support); "" where none does.
std::string support_doubt(const FitResult& r) {
  if (!r.support) return "";
  const ModelSelection& s = *r.support;
  const VariantScore& fitted = s.variants[variant_index(s, r.options.model)];
  const VariantScore& best = s.variants[s.chosen];
  if (!(best.held_out_rmse_Nm <= (1.0 - kSupportDoubt) * fitted.held_out_rmse_Nm)) return "";
  std::ostringstream m;
  m << "the log supports " << best.name << ": held-out torque error " << best.held_out_rmse_Nm
    << " N m against " << fitted.held_out_rmse_Nm << " N m for the " << fitted.name << " fitted ("
    << s.folds << " time blocks); fit with ";
  const std::string flags = std::string(best.model.per_joint ? " --per-joint" : "") +
                            (best.model.offsets ? " --offsets" : "") +
                            (best.model.torque_gains ? " --torque-gains" : "") +
                            (best.model.load_friction ? " --load-friction" : "");
  // --model auto chooses among the delta model's variants.
  if (r.options.model.name == "delta") {
    m << "--model auto (or" << flags << ")";
  } else {
    m << "--model " << r.options.model.name << flags;
  }
  return m.str();
}

}  // namespace

std::vector<std::string> doubts_of(const FitResult& r) {
  std::vector<std::string> doubts;
  if (const std::string masses = implausible_masses(r); !masses.empty()) doubts.push_back(masses);
  std::ostringstream m;
  if (r.condition_number_scaled > kConditionDoubt) {
    m << "the log excites the parameters poorly: the scaled condition number is "
      << r.condition_number_scaled << " (a good excitation's is about 30); a larger or richer "
      << "motion (host_id design) separates them";
    doubts.push_back(m.str());
  }
  std::string loose;
  double loosest = 0;
  std::string pinned;
  std::size_t pinned_count = 0;
  for (const ParameterEstimate& e : r.parameters) {
    if (!e.identifiable()) continue;
    if (e.at_bound) {
      pinned += (pinned_count++ ? ", " : "") + e.info.name;
    } else if (std::isfinite(e.std_torque_share) && e.std_torque_share > kStdShareDoubt) {
      loose += (loose.empty() ? "" : ", ") + e.info.name;
      loosest = std::max(loosest, e.std_torque_share);
    }
  }
  if (!loose.empty()) {
    m.str("");
    m << loose << ": the log determines them so loosely that one standard deviation stands for "
      << "up to " << 100.0 * loosest << " % of the torque; their values are not to be used";
    doubts.push_back(m.str());
  }
  if (pinned_count >= kPinnedDoubt) {
    doubts.push_back(std::to_string(pinned_count) + " parameters sit at their bound 0 (" + pinned +
                     "): the log cannot tell them from 0");
  }
  if (const std::string shape = friction_shape_doubt(r); !shape.empty()) doubts.push_back(shape);
  if (const std::string stiffness = stiffness_doubt(r); !stiffness.empty()) {
    doubts.push_back(stiffness);
  }
  for (const std::string& d : {changing_doubt(r), support_doubt(r)}) {
    if (!d.empty()) doubts.push_back(d);
  }
  return doubts;
}

}  // namespace host_id
