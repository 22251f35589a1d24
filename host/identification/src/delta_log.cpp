#include "host_id/delta_log.hpp"

namespace host_id {

std::optional<std::string> DeltaLog::metadata_value(std::string_view key) const {
  for (const auto& [k, v] : metadata) {
    if (k == key) return v;
  }
  return std::nullopt;
}

void release_samples(DeltaLog& log) {
  log.t = Series{};
  for (unsigned j = 0; j < 3; ++j) {
    log.q[j] = Series{};
    log.tau[j] = Series{};
    log.qd[j] = Series{};
    log.qdd[j] = Series{};
  }
  log.seq = std::vector<std::uint64_t>{};
  log.extra_columns.clear();
  log.extra_columns.shrink_to_fit();
}

}  // namespace host_id
