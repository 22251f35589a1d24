// Which model variant the data support (`host_id fit --model auto`,
// docs/model-selection.md, "Choosing the model"): the delta or lumped model
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
#include "host_id/model_support.hpp"
#include "host_id/regression.hpp"

namespace host_id {

// Throws InputError for paper14 (no variants) or a log too short for
// `folds` blocks.
ModelSelection select_model(const DeltaLog& log, const FitOptions& options, unsigned folds = 5);

// The same judgement from a fit's own regression, without preprocessing the
// log again (what `fit` reports as the model's support): a per-joint arm
// column is the shared one in its joint's rows alone, and a torque offset
// is 1 in its joint's rows (a filtered constant). rows: the equations the
// fit took (the fast ones first). It agrees with select_model() on the same
// log to rounding. Throws InputError for paper14 or too short a regression.
// The folds' moments are taken on `threads` threads (0: all cores). With
// `grams`, the first `rows` rows' Gram matrices per joint go there too
// (for solve_least_squares, which then makes no pass of its own).
ModelSelection judge_support(const Model& fitted, const ModelOptions& fitted_options,
                             const Regression& r, std::size_t rows, unsigned folds = 5,
                             unsigned threads = 0, JointGrams* grams = nullptr);

// The held-out torque RMSE of one model over `folds` time blocks of its
// regression's first `rows` rows (each block predicted by the bounded fit
// of the others), on `threads` threads. Throws InputError for too short a
// regression. left_out: columns the fits leave out (the model without
// those terms).
double held_out_rmse(const Model& model, const Regression& r, std::size_t rows, unsigned folds,
                     unsigned threads = 0, const std::vector<std::size_t>& left_out = {});

}  // namespace host_id
