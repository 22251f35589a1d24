// What `fit` reports of the model variants the data support (the delta
// and lumped models, arms shared or per joint, with or without torque
// offsets), judged by held-out torque error over time blocks of the fit log
// (model_selection.hpp computes it).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "host_id/model.hpp"

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

// The index of a variant in ModelSelection::variants: shared, per-joint,
// shared with offsets, per-joint with offsets.
constexpr std::size_t variant_index(const ModelOptions& m) {
  return (m.offsets ? 2u : 0u) + (m.per_joint ? 1u : 0u);
}

}  // namespace host_id
