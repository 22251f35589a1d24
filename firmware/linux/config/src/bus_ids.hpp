// Internal to the configuration: the bus's COB-IDs checked for collisions
// once every drive is planned (plan_drives).
#pragma once

#include <string>
#include <vector>

#include "fw_linux/drive_plan.hpp"

namespace fw_linux::planning {

// Appends one problem per drive whose frames share a COB-ID with the
// controller's or an earlier drive's, naming each frame.
void check_bus_ids(const DrivePlans& plans, std::vector<std::string>& problems);

}  // namespace fw_linux::planning
