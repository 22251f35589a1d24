// The controller's registers in words, for `status` and `excite`.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace host_id {

std::string fault_text(std::int64_t code);   // "3 (heartbeat lost)"
std::string state_text(std::int64_t state);  // "ready"
const char* run_result_text(std::int64_t result);
std::string trajectory_name(std::int64_t id);  // "path1", or "#7" for an unknown id
// The named register's value in its unit.
double scaled(const char* name, const std::vector<std::uint16_t>& table);

}  // namespace host_id
