// A saved model (delta/identified_model.hpp) as the controller runs it: its
// parameters in the Q formats of delta/fixed/dynamics.hpp, checked whole
// first. The controller's feed_forward.model and `host_id model load` both
// go through here, so a model one accepts the other accepts too.
#pragma once

#include <string>
#include <vector>

#include "delta/controller/model_record.hpp"
#include "delta/fixed/dynamics.hpp"
#include "delta/geometry.hpp"
#include "delta/identified_model.hpp"

namespace delta {

// Everything that keeps m from running on a controller with geometry g:
// another geometry (naming both), no geometry recorded, a value outside its
// format or a negative mass, inertia or friction (naming the parameter and
// its range). Empty: it can run.
std::vector<std::string> model_problems(const IdentifiedModel& m, const Geometry& g);

// The parameters in Q formats, rounded to nearest (call model_problems()
// first: out-of-range values saturate here).
fx::ModelParametersQ model_parameters_q(const IdentifiedModel& m);

// The geometry in Q7.24, as the controller holds it.
fx::GeometryQ geometry_q(const Geometry& g);

// The model as the controller transfers and stores it (0x2200:1; call
// model_problems() first), and back (for `host_id model show`: the values
// as the controller holds them).
controller::ModelRecord model_record(const IdentifiedModel& m);
IdentifiedModel identified_model(const controller::ModelRecord& r);

// The collision thresholds in the controller's format (Q12.19; call
// model_problems() first).
fx::CollisionThresholdsQ collision_thresholds_q(const CollisionThresholds& t);

// Whether two geometries are the same robot (every length within 1 um).
bool same_geometry(const Geometry& a, const Geometry& b);

// "a=0.2 b=0.46 R=0.1 r=0.035 m", for messages.
std::string describe_geometry(const Geometry& g);

}  // namespace delta
