#pragma once

#include <string>

namespace delta {

// Reads a whole file with one read() into a buffer of the file's size (more
// reads only where the file grows or is not a regular file). InputError
// names the file and the system's reason when it cannot be read.
std::string read_whole_file(const std::string& path);

}  // namespace delta
