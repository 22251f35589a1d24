#pragma once

#include <string>

#include "delta/atomic_file.hpp"

namespace host_id {

using delta::write_file_atomically;

// Where a command keeps what it has when it could not finish:
// "run.csv" -> "run.partial.csv"; "run" -> "run.partial".
std::string partial_log_path(const std::string& path);

}  // namespace host_id
