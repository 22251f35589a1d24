// A directory of this process's own for the files a test writes, removed
// with everything in it when the process ends. ctest runs each test as a
// process of its own, in parallel, so a shared name would let two tests
// overwrite each other's files, and a file named after the process id
// alone stays behind in /tmp after every run.
#pragma once

#include <stdlib.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

namespace testsupport {

class ScratchDirectory {
 public:
  // Under $TMPDIR (or /tmp), named after `prefix`.
  explicit ScratchDirectory(const std::string& prefix) {
    const char* tmp = std::getenv("TMPDIR");
    std::string pattern =
        std::string(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") + "/" + prefix + ".XXXXXX";
    if (::mkdtemp(pattern.data()) == nullptr) {
      throw std::runtime_error("cannot make a scratch directory " + pattern);
    }
    path_ = pattern;
  }
  ~ScratchDirectory() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDirectory(const ScratchDirectory&) = delete;
  ScratchDirectory& operator=(const ScratchDirectory&) = delete;

  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }

 private:
  std::string path_;
};

// One per process, made on first use and removed at exit.
inline const ScratchDirectory& process_scratch(const std::string& prefix) {
  static const ScratchDirectory directory(prefix);
  return directory;
}

}  // namespace testsupport
