#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

namespace delta {

// A file's bytes in a buffer of its size, not cleared before the read
// fills it (for a large log, clearing would be one more pass over memory).
class FileBytes {
 public:
  FileBytes() = default;
  std::string_view view() const { return {bytes_.get(), size_}; }

 private:
  friend FileBytes read_file_bytes(const std::string& path);
  std::unique_ptr<char[]> bytes_;
  std::size_t size_{0};
};

// Reads a whole file with one read() into a buffer of the file's size (more
// reads only where the file grows or is not a regular file). InputError
// names the file and the system's reason when it cannot be read.
FileBytes read_file_bytes(const std::string& path);

// The same, as a string (for small files: configuration, JSON).
std::string read_whole_file(const std::string& path);

}  // namespace delta
