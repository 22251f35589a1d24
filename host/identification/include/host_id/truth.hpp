// What a fit should find on a robot whose description is known: each
// parameter's truth for the chosen model (docs/model.md, "The truth
// of a multibody robot"), so that `host_id fit --truth ROBOT.json` can print
// the error beside each estimate.
#pragma once

#include <map>
#include <string>

#include "delta/robot_description.hpp"
#include "host_id/model.hpp"

namespace host_id {

// Parameter name -> its truth, for the parameters that have one: every
// parameter of `delta` and `lumped` (shared parameters: the mean of the three joints'),
// none of `paper14` (its coefficients lump constant lambdas).
std::map<std::string, double> parameter_truth(const ModelOptions& model,
                                              const delta::RobotDescription& robot);

}  // namespace host_id
