// Which model variant the data support (`host_id fit --model auto`,
// docs/identification.md, "Choosing the model"): the delta or lumped model
// with shared or per-joint arm parameters, with or without torque offsets,
// judged by their held-out torque error over time blocks of the fit log
// (k-fold cross-validation). The log is preprocessed once, with the
// largest variant; each smaller variant's columns are sums or subsets of
// its columns (filtering is linear), and each fold's fit is a bounded least
// squares from moments.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"

namespace host_id {

struct VariantScore {
  std::string name;  // "shared arms", "per-joint arms, offsets", ...
  ModelOptions model;
  std::size_t parameters{0};
  double held_out_rmse_Nm{0};  // over every fold's held-out rows
};

struct ModelSelection {
  unsigned folds{0};
  std::vector<VariantScore> variants;  // fewest parameters first
  std::size_t chosen{0};
  // The variant that explains the log as well without being nested in the
  // chosen one (per-joint arms against torque offsets); "" if none.
  std::string alike;
  std::string reason;
};

// A variant with more parameters is chosen only where it lowers the
// held-out error by more than this fraction against every simpler one.
inline constexpr double kSelectionMargin = 0.01;

// Throws InputError for paper14 (no variants) or a log too short for
// `folds` blocks.
ModelSelection select_model(const DeltaLog& log, const FitOptions& options, unsigned folds = 5);

}  // namespace host_id
