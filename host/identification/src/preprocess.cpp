#include "host_id/preprocess.hpp"

#include "preprocess_rows.hpp"
#include "preprocess_states.hpp"

namespace host_id {

using preprocessing::design_filter;
using preprocessing::FilterDesign;
using preprocessing::joint_states;
using preprocessing::layout_of;
using preprocessing::regression_of;
using preprocessing::report_of;
using preprocessing::RowLayout;
using preprocessing::States;

namespace {

// The joint states of the log, then after_states() (which may free the
// log's samples: only its name, geometry and gravity are used after it),
// then the regression.
template <class AfterStates>
Preprocessed preprocess_with(const Model& model, const DeltaLog& log, const PrepareOptions& options,
                             unsigned threads, AfterStates after_states) {
  const FilterDesign design = design_filter(log, options);
  Preprocessed out;
  States states = joint_states(log, design, threads);
  out.report = report_of(log, design, options, states);
  after_states();
  const RowLayout layout = layout_of(states, design, options.slow_rows_last_below_rad_s, log.name);
  out.fast_rows = layout.fast_rows();
  out.regression = regression_of(model, log, states, design, layout, threads, true);
  return out;
}

}  // namespace

Preprocessed preprocess(const Model& model, const DeltaLog& log, const PrepareOptions& options,
                        unsigned threads) {
  return preprocess_with(model, log, options, threads, [] {});
}

Preprocessed preprocess_releasing(const Model& model, DeltaLog& log, const PrepareOptions& options,
                                  unsigned threads) {
  return preprocess_with(model, log, options, threads, [&log] { release_samples(log); });
}

}  // namespace host_id
