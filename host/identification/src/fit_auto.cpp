#include "host_id/fit_auto.hpp"

#include <utility>

namespace host_id {

AutoFit fit_auto(DeltaLog log, const std::function<DeltaLog()>& read_again, FitOptions options,
                 const std::vector<const DeltaLog*>& validation, bool keep_predictions) {
  AutoFit out;
  out.result = fit_log(std::move(log), options, validation, keep_predictions);
  out.selection = out.result.support;
  const std::optional<CoggingSearch> search = out.result.cogging;
  const bool cogging = search && search->found();
  const bool other_variant =
      out.selection && out.selection->chosen != variant_index(*out.selection, options.model);
  if (!other_variant && !cogging) return out;
  // Each further fit keeps the first fit's search.
  const auto fit_again = [&] {
    out.result = fit_log(read_again(), options, validation, keep_predictions);
    out.result.cogging = search;
  };
  const ModelOptions given = options.model;
  if (out.selection) options.model = out.selection->variants[out.selection->chosen].model;
  options.model.gearbox_compliance_rad_per_Nm = given.gearbox_compliance_rad_per_Nm;
  if (cogging) options.model.cogging_periods_per_rev = search->periods_per_rev;
  fit_again();
  // With the cogging terms in, the arms and offsets are chosen again.
  const std::optional<ModelSelection> again = out.result.support;
  if (cogging && again && again->chosen != variant_index(*again, options.model)) {
    options.model = again->variants[again->chosen].model;
    out.selection = again;
    fit_again();
  }
  const std::optional<CoggingSupport> judged = out.result.cogging_support;
  if (cogging && judged && !judged->supported) {
    options.model.cogging_periods_per_rev = given.cogging_periods_per_rev;
    fit_again();
    out.result.cogging_support = judged;
  }
  return out;
}

}  // namespace host_id
