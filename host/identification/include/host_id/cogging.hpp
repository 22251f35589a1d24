// Cogging in a fit's residual (docs/model.md, "Cogging"): a torque
// periodic in the motor's angle, so in the joint's, a sin(n q) + b cos(n q)
// with n periods per joint revolution (the motor's periods per revolution
// times the gear ratio). No model term holds it unless asked; the fit's
// own residual shows it as a peak of its spectrum over the joint's angle.
//
// Per joint: the residual (logged torque less the model's, both filtered)
// is averaged into bins of the angle under a Hann window, and its power at
// n taken on a grid from kMinCoggingPeriods (at least two periods over the
// joint's range) up to where the cogging's frequency at the joint's
// lower-quartile speed reaches the fit's cut-off (above it the filtered
// torque no longer holds it). A peak is cogging where its power is at
// least kCoggingPeakRatio times the median power from half its n to twice
// it, its own lobe left out, and its sinusoid's RMS is at least
// kLeastCoggingShare of the residual's (noise's highest peaks can stand
// high over the median, but hold a few % of the residual). n is then
// refined to where a sinusoid fitted beside a cubic in q (the smooth
// errors) explains most. The fit with the term then judges it by its
// held-out error (CoggingSupport).
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <vector>

#include "delta/dynamics.hpp"

namespace host_id {

struct DeltaLog;    // delta_log.hpp
struct Prediction;  // identify.hpp

inline constexpr double kMinCoggingPeriods = 8.0;  // per joint revolution
inline constexpr double kCoggingPeakRatio = 10.0;
inline constexpr double kLeastCoggingShare = 0.3;

// The logged angles of every `stride`-th sample, kept for the search once
// the log's samples are freed.
struct AngleTrack {
  std::vector<double> t_s;
  std::array<std::vector<double>, 3> q_rad;
};
// The stride keeps 4 samples per period of the cut-off.
AngleTrack angle_track(const DeltaLog& log, double cutoff_hz);

struct CoggingSearch {
  delta::Joint3 periods_per_rev{};  // 0 where the joint's residual has no peak
  delta::Joint3 amplitude_Nm{};     // of the residual's component at that n
  delta::Joint3 peak_ratio{};       // the peak's power over the median around it (0: no search)
  bool found() const {
    return periods_per_rev[0] > 0.0 || periods_per_rev[1] > 0.0 || periods_per_rev[2] > 0.0;
  }
};

// None where no joint moved enough to tell (a range under 0.05 rad, or
// fewer than 200 samples matched).
std::optional<CoggingSearch> find_cogging(const Prediction& fitted, const AngleTrack& angles,
                                          double cutoff_hz);

// Judged by the fit with the term: its held-out torque error (over the
// support's time blocks) with and without the cogging columns.
struct CoggingSupport {
  double held_out_with_Nm{0};
  double held_out_without_Nm{0};
  bool supported{false};  // lower by more than kDriveTrainMargin
};

}  // namespace host_id
