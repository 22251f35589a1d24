// Measured against predicted torque per joint, with the residual, as SVG
// (like the paper's Fig. 3): one block of three joints per log.
#pragma once

#include <string>
#include <vector>

#include "host_id/identify.hpp"

namespace host_id {

std::string svg_torque_plot(const std::vector<Prediction>& logs, const std::string& title);

}  // namespace host_id
