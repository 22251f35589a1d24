// A log preprocessed once for fits that differ only in the friction's
// shape: the joint states and row layout kept, the shape's columns
// recomputed and filtered for each shape asked for.
#include <algorithm>
#include <array>
#include <memory>
#include <vector>

#include "host_id/parallel.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/signal.hpp"
#include "preprocess_rows.hpp"
#include "preprocess_states.hpp"

namespace host_id {

using preprocessing::design_filter;
using preprocessing::FilterDesign;
using preprocessing::joint_states;
using preprocessing::kSamplesPerThread;
using preprocessing::layout_of;
using preprocessing::regression_of;
using preprocessing::report_of;
using preprocessing::RowLayout;
using preprocessing::Segment;
using preprocessing::States;

namespace {

// The columns of joint j's shape terms in the model's rows, and how many.
struct ShapeColumns {
  std::array<std::size_t, Model::kMaxShapeTerms> column{};
  std::size_t count{0};
};

// The shape terms of joint j over segment si: computed from each sample's
// velocity, filtered as fill_rows and filter_columns build and filter
// them (a lane's bits do not depend on the others), and the kept samples'
// values put into psi. Returns whether each term is anywhere nonzero.
std::array<bool, Model::kMaxShapeTerms> refill_shape_terms(const Model& model, const States& s,
                                                           const RowLayout& layout,
                                                           const FilterDesign& d, std::size_t si,
                                                           unsigned j, const ShapeColumns& shape,
                                                           Regression& r) {
  const Segment& seg = s.segments[si];
  const std::size_t n = seg.end - seg.begin;
  const std::size_t lanes = shape.count;
  std::vector<double> values(n * lanes);
  std::array<std::size_t, Model::kMaxShapeTerms> columns{};
  std::array<bool, Model::kMaxShapeTerms> nonzero{};
  for (std::size_t q = 0; q < n; ++q) {
    double* v = &values[q * lanes];
    model.shape_terms(j, s.states[seg.begin + q].qd_rad_s[j], columns.data(), v);
    for (std::size_t t = 0; t < lanes; ++t) nonzero[t] = nonzero[t] || v[t] != 0.0;
  }
  if (!d.logged_derivatives) {
    filtfilt_lanes(d.filter, n, lanes, d.pad, [&](std::size_t q) { return &values[q * lanes]; });
  }
  for (std::size_t q = 0; q < n; ++q) {
    bool side = false;
    const std::size_t i = layout.place(si, q, n, side);
    if (side) continue;
    const auto row = static_cast<Eigen::Index>(layout.row(i, j));
    for (std::size_t t = 0; t < lanes; ++t) {
      r.psi(row, static_cast<Eigen::Index>(shape.column[t])) = values[q * lanes + t];
    }
  }
  return nonzero;
}

// The columns of r that carry the friction's shape recomputed for model's
// shape, one task per segment and joint; the joints' nonzero columns
// follow.
void refill_shape_columns(const Model& model, const States& s, const RowLayout& layout,
                          const FilterDesign& d, unsigned threads, Regression& r) {
  std::array<ShapeColumns, 3> shape;
  std::array<double, Model::kMaxShapeTerms> unused{};
  for (unsigned j = 0; j < 3; ++j) {
    shape[j].count = model.shape_terms(j, 0.0, shape[j].column.data(), unused.data());
  }
  const std::size_t tasks = 3 * s.segments.size();
  std::vector<std::array<bool, Model::kMaxShapeTerms>> nonzero(tasks);
  run_tasks(tasks, workers_for(s.size(), threads, kSamplesPerThread / 3),
            [&](std::size_t, std::size_t task) {
              const auto j = static_cast<unsigned>(task % 3);
              nonzero[task] = refill_shape_terms(model, s, layout, d, task / 3, j, shape[j], r);
            });
  for (unsigned j = 0; j < 3; ++j) {
    std::vector<Eigen::Index>& columns = r.joint_columns[j];
    for (std::size_t t = 0; t < shape[j].count; ++t) {
      bool any = false;
      for (std::size_t task = j; task < tasks; task += 3) any = any || nonzero[task][t];
      const auto c = static_cast<Eigen::Index>(shape[j].column[t]);
      const auto at = std::lower_bound(columns.begin(), columns.end(), c);
      const bool listed = at != columns.end() && *at == c;
      if (any && !listed) columns.insert(at, c);
      if (!any && listed) columns.erase(at);
    }
  }
}

}  // namespace

// What a fit that searches the friction's shape keeps of its log: the
// filter, the joint states, the row layout, and the regression of the last
// shape asked for.
struct ShapePreprocess::Kept {
  Kept(const Model& model, const DeltaLog& log, const PrepareOptions& options, unsigned t)
      : design(design_filter(log, options)),
        states(joint_states(log, design, t)),
        layout(layout_of(states, design, options.slow_rows_last_below_rad_s, log.name)),
        threads(t) {
    out.report = report_of(log, design, options, states);
    out.fast_rows = layout.fast_rows();
    out.regression = regression_of(model, log, states, design, layout, t, false);
  }
  FilterDesign design;
  States states;
  RowLayout layout;
  unsigned threads;
  Preprocessed out;
};

ShapePreprocess::ShapePreprocess(const Model& model, const DeltaLog& log,
                                 const PrepareOptions& options, unsigned threads)
    : kept_(std::make_unique<Kept>(model, log, options, threads)) {}

ShapePreprocess::~ShapePreprocess() = default;

const Preprocessed& ShapePreprocess::with_shape(const Model& model) {
  refill_shape_columns(model, kept_->states, kept_->layout, kept_->design, kept_->threads,
                       kept_->out.regression);
  kept_->out.regression.measured = MeasuredMoments{};
  return kept_->out;
}

}  // namespace host_id
