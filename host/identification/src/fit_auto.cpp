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
  // The variant the first judgement chose, with what was given (the
  // variants carry what the fit found: a searched stiffness).
  const ModelOptions given = options.model;
  const std::optional<ModelSelection> first_selection = out.selection;
  const auto with_given = [&given](ModelOptions m) {
    m.gearbox_compliance_rad_per_Nm = given.gearbox_compliance_rad_per_Nm;
    m.cogging_periods_per_rev = given.cogging_periods_per_rev;
    return m;
  };
  const ModelOptions chosen =
      with_given(out.selection ? out.selection->variants[out.selection->chosen].model : given);
  // Each further fit keeps the first fit's search.
  const auto fit_with = [&](const ModelOptions& m) {
    options.model = m;
    out.result = fit_log(read_again(), options, validation, keep_predictions);
    out.result.cogging = search;
  };
  if (!cogging) {
    fit_with(chosen);
    return out;
  }
  ModelOptions with = chosen;
  with.cogging_periods_per_rev = search->periods_per_rev;
  fit_with(with);
  // With the cogging terms in, the arms and offsets are chosen again.
  const std::optional<ModelSelection> again = out.result.support;
  if (again && again->chosen != variant_index(*again, with)) {
    with = with_given(again->variants[again->chosen].model);
    with.cogging_periods_per_rev = search->periods_per_rev;
    out.selection = again;
    fit_with(with);
  }
  // Kept only where the log supports the terms; else the first choice.
  const std::optional<CoggingSupport> judged = out.result.cogging_support;
  if (judged && !judged->supported) {
    out.selection = first_selection;
    fit_with(chosen);
    out.result.cogging_support = judged;
  }
  return out;
}

}  // namespace host_id
