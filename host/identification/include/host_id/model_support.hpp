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
  // Shared arms, per-joint arms, each with torque offsets; then the chosen
  // of those with torque gains, with load friction, with both.
  std::vector<VariantScore> variants;
  std::size_t chosen{0};
  // The variant that explains the log as well without being nested in the
  // chosen one (per-joint arms against torque offsets); "" if none.
  std::string alike;
  std::string reason;
};

// A variant with more parameters is chosen only where it lowers the
// held-out error by more than this fraction against every simpler one.
inline constexpr double kSelectionMargin = 0.01;
// The drive train's terms are written with the measured torque, which holds
// whatever the model lacks as well (cogging, noise-free effects of every
// kind): such a term lowers the held-out error a little on any robot (2-6 %
// on our rigid, ideal ones), and is taken only where it lowers it by more
// than this fraction (14-51 % on robots that have the effect).
inline constexpr double kDriveTrainMargin = 0.10;

// The index of the variant with m's arms, offsets and drive-train terms in
// s.variants; s.variants.size() where none has them.
inline std::size_t variant_index(const ModelSelection& s, const ModelOptions& m) {
  for (std::size_t i = 0; i < s.variants.size(); ++i) {
    const ModelOptions& v = s.variants[i].model;
    if (v.per_joint == m.per_joint && v.offsets == m.offsets &&
        v.load_friction == m.load_friction && v.torque_gains == m.torque_gains) {
      return i;
    }
  }
  return s.variants.size();
}

}  // namespace host_id
