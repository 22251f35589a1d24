// Parameters fitted on one robot do not apply to another: the check that a
// log, a saved result and a robot description are of the same geometry.
#pragma once

#include <iosfwd>
#include <optional>
#include <string>

#include "delta/geometry.hpp"

namespace host_id {

// The lengths in words: "upper arm 0.2 m, forearm 0.46 m, base 0.1 m,
// platform 0.035 m".
std::string geometry_text(const delta::Geometry& g);

// Whether a and b are the same geometry (each length to 1e-9 relative:
// both are written as round-trip numbers).
bool same_geometry(const delta::Geometry& a, const delta::Geometry& b);

// When `found` (of `what`, e.g. "LOG.csv") is not `expected` (of `whose`,
// e.g. "RESULT.json was fitted for"): with allowed, a warning on err;
// otherwise delta::InputError naming both geometries and the option that
// allows it.
void check_geometry(const std::string& what, const delta::Geometry& found, const std::string& whose,
                    const delta::Geometry& expected, bool allowed, std::ostream& err);

// The same for a log against a saved result (`result`), whose geometry an
// older host_id did not record: then a warning on err that the log's robot
// cannot be checked against the fitted one.
void check_result_geometry(const std::string& log_path, const delta::Geometry& log_geometry,
                           const std::string& result, const std::optional<delta::Geometry>& fitted,
                           bool allowed, std::ostream& err);

}  // namespace host_id
