// The friction's nonlinear parameters by variable projection: PSO searches
// the Coulomb smoothing velocity w (and the Stribeck velocity vs where the
// model has a Stribeck term) in log scale, and for each candidate the
// linear parameters are solved exactly (bounded least squares on the
// preprocessed log), so the swarm only sees the profiled cost
// (docs/model.md, "The friction's shape").
#pragma once

#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"

namespace host_id {

// The search box, rad/s.
constexpr double kSmoothingMinRadS = 1e-3, kSmoothingMaxRadS = 0.2;
constexpr double kStribeckMinRadS = 0.01, kStribeckMaxRadS = 1.0;

// Throws delta::InputError as fit_log does (the log, the options).
FrictionShapeResult fit_friction_shape(const DeltaLog& log, const FitOptions& options);

}  // namespace host_id
