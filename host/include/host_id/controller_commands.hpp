// `host_id status` and `host_id excite`: the controller over Modbus
// (docs/modbus.md), and for excite its CAN log recorded meanwhile.
#pragma once

#include <iosfwd>
#include <string>
#include <vector>

namespace host_id {

int cmd_status(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);
int cmd_excite(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

// "run.csv" -> "run.partial.csv"; "run" -> "run.partial".
std::string partial_log_path(const std::string& path);

}  // namespace host_id
