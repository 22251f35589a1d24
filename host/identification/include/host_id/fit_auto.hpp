// --model auto, the default fit (docs/model-selection.md): the shared
// arms' fit judges the model's variants on its own rows and searches its
// residual for cogging (cogging.hpp); another variant the log supports, or
// cogging found, is fitted again, the arms and offsets chosen again with
// the cogging terms in, and those terms kept only where they lower the
// held-out error by more than kDriveTrainMargin.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"
#include "host_id/model_support.hpp"

namespace host_id {

struct AutoFit {
  FitResult result;
  // The choice the result fitted; none for a log too short to judge.
  std::optional<ModelSelection> selection;
};

// options.model: the shared arms (with any gearbox compliance given). The
// first fit takes `log`; each further one `read_again()` (the CLI reads
// its file again: a long log is never held twice).
AutoFit fit_auto(DeltaLog log, const std::function<DeltaLog()>& read_again, FitOptions options,
                 const std::vector<const DeltaLog*>& validation = {},
                 bool keep_predictions = false);

}  // namespace host_id
