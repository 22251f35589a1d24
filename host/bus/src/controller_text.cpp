#include "host_id/controller_text.hpp"

#include "delta/controller/vocabulary.hpp"
#include "host_id/controller_link.hpp"

namespace host_id {

namespace mb = delta::modbus;

std::string fault_text(std::int64_t code) {
  return std::to_string(code) + " (" +
         delta::controller::fault_name(static_cast<delta::controller::Fault>(code)) + ")";
}

std::string state_text(std::int64_t state) {
  return delta::controller::state_name(static_cast<delta::controller::State>(state));
}

const char* run_result_text(std::int64_t result) {
  switch (static_cast<mb::RunResult>(result)) {
    case mb::RunResult::kNone:
      return "none yet";
    case mb::RunResult::kRunning:
      return "running";
    case mb::RunResult::kFinished:
      return "finished";
    case mb::RunResult::kStopped:
      return "stopped";
    case mb::RunResult::kFaulted:
      return "ended by a fault";
  }
  return "unknown";
}

std::string trajectory_name(std::int64_t id) {
  if (id >= 0 && static_cast<std::size_t>(id) < delta::controller::kTrajectoryNames.size()) {
    return delta::controller::trajectory_name(static_cast<delta::controller::TrajectoryId>(id));
  }
  // Appended, not "#" + to_string(): GCC 12 warns falsely (-Wrestrict) on that.
  std::string unknown = "#";
  unknown += std::to_string(id);
  return unknown;
}

double scaled(const char* name, const std::vector<std::uint16_t>& table) {
  return scaled(mb::named(name), table);
}

}  // namespace host_id
