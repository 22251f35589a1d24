// One joint logged with the sign opposite to docs/conventions.md's: its
// angle (an encoder counting the other way) or its torque (a drive whose
// positive current turns the joint towards negative angles). The model
// then cannot explain that joint; a fit absorbs what it can (a torque gain
// of -1, offsets, parameters at their bounds) and its error stays large.
// The check fits the delta model with per-joint arms (bounded least
// squares) to the log as it is and with each joint's angle or torque
// negated, and names the one negation that explains the log far better.
#pragma once

#include <optional>
#include <string>

#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"

namespace host_id {

// A negation must lower the cost this many times to be named.
inline constexpr double kInvertedJointRatio = 4.0;

struct InvertedJoint {
  unsigned joint{0};  // 0..2
  bool angle{false};  // the angle, else the torque
  double cost_as_logged_Nm2{0}, cost_negated_Nm2{0};
};

// The joint whose negated angle or torque lowers the bounded fit's cost
// more than kInvertedJointRatio times (the best one), if any; preprocessed
// with `options.prepare`.
std::optional<InvertedJoint> inverted_joint(const DeltaLog& log, const FitOptions& options);

// What to tell the user: the joint, the column, both costs, what to do.
std::string inverted_joint_message(const InvertedJoint& j, const std::string& log_name);

// Whether a fit looks like one of a log with an inverted joint: a joint's
// model error (filtered) above kSuspectErrorShare of its RMS torque, or a
// torque gain that makes a joint's torque constant negative (gap above 1).
inline constexpr double kSuspectErrorShare = 0.05;
bool suspect_inverted_joint(const FitResult& r);

}  // namespace host_id
