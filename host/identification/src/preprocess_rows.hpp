// preprocess()'s regression, internal to host_id_identification: where
// each kept sample's three rows go (RowLayout), and the regressor built in
// place from the joint states, labelled and filtered like tau.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "host_id/delta_log.hpp"
#include "host_id/model.hpp"
#include "host_id/regression.hpp"
#include "preprocess_states.hpp"

namespace host_id::preprocessing {

// Where each sample's three rows go. The samples kept after trimming go
// straight into the regression (rows 3i..3i+2 of kept sample i); the few
// trimmed at each segment end, which only the filter needs, go into a side
// buffer (rows 3t..3t+2 of trimmed sample t). So the regressor is built in
// its final place, with no full-size scratch copy.
class RowLayout {
 public:
  RowLayout(const std::vector<Segment>& segments, std::size_t trim) : trim_(trim) {
    for (const Segment& seg : segments) {
      kept_before_.push_back(kept_);
      side_before_.push_back(side_);
      kept_ += seg.end - seg.begin - 2 * trim;
      side_ += 2 * trim;
    }
  }
  std::size_t kept() const { return kept_; }
  std::size_t trimmed() const { return side_; }
  // Sample q of segment s (of length len): its kept index, or its side index
  // with on_side set.
  std::size_t place(std::size_t s, std::size_t q, std::size_t len, bool& on_side) const {
    on_side = q < trim_ || q >= len - trim_;
    if (!on_side) return kept_before_[s] + q - trim_;
    return side_before_[s] + (q < trim_ ? q : q - (len - 2 * trim_));
  }
  // Puts the rows of joints slower than slow_below_rad_s (|qd| at their
  // sample) after all the others, each group in time order. Without it,
  // joint j of kept sample i is row 3 i + j.
  void order_rows(const std::vector<Segment>& segments, const States& s, double slow_below_rad_s,
                  const std::string& log_name);
  // The regression's row of joint j of kept sample i.
  std::size_t row(std::size_t i, unsigned j) const {
    return rows_.empty() ? 3 * i + j : rows_[3 * i + j];
  }
  std::size_t fast_rows() const { return rows_.empty() ? 3 * kept_ : fast_; }

 private:
  std::size_t trim_;
  std::size_t kept_{0}, side_{0}, fast_{0};
  std::vector<std::size_t> kept_before_, side_before_;
  std::vector<std::uint32_t> rows_;  // [3 i + j]; empty: 3 i + j
};

// Where the states' samples go: the kept ones in the row order asked for
// (joints slower than slow_below_rad_s last), the trimmed ones aside.
RowLayout layout_of(const States& s, const FilterDesign& d, double slow_below_rad_s,
                    const std::string& log_name);

// The regression of the states: built in place, in the layout's row
// order, labelled, filtered, trimmed. With free_states the states are
// freed once the rows are built, before filtering needs its buffers.
Regression regression_of(const Model& model, const DeltaLog& log, States& s, const FilterDesign& d,
                         const RowLayout& layout, unsigned threads, bool free_states);

}  // namespace host_id::preprocessing
