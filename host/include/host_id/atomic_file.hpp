#pragma once

#include <sys/types.h>

#include <string>
#include <string_view>

namespace host_id {

// Writes content to path atomically: into a temporary file in the same
// folder, flushed to disk, then renamed over path. On any failure the
// temporary file is removed, path is left as it was, and delta::InputError is
// thrown. The file gets `mode` (0600 for a secret key).
void write_file_atomically(const std::string& path, std::string_view content, mode_t mode = 0644);

// Where a command keeps what it has when it could not finish:
// "run.csv" -> "run.partial.csv"; "run" -> "run.partial".
std::string partial_log_path(const std::string& path);

}  // namespace host_id
