#include "delta/read_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "delta/input_error.hpp"

namespace delta {

namespace {

class Descriptor {
 public:
  explicit Descriptor(int fd) : fd_(fd) {}
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

}  // namespace

FileBytes read_file_bytes(const std::string& path) {
  const Descriptor fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
  if (fd.get() < 0) throw InputError(path + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd.get(), &st) != 0)
    throw InputError(path + ": cannot stat: " + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) throw InputError(path + ": is a folder, not a file");
  // A regular file's size is known (one byte more shows its end in the same
  // read); a pipe or a growing file reads on in blocks until end of file.
  std::size_t capacity = S_ISREG(st.st_mode) ? static_cast<std::size_t>(st.st_size) + 1 : 65536;
  FileBytes bytes;
  bytes.bytes_ = std::make_unique_for_overwrite<char[]>(capacity);
  std::size_t used = 0;
  for (;;) {
    if (used == capacity) {
      auto larger = std::make_unique_for_overwrite<char[]>(capacity * 2);
      std::memcpy(larger.get(), bytes.bytes_.get(), used);
      bytes.bytes_ = std::move(larger);
      capacity *= 2;
    }
    const ssize_t n = ::read(fd.get(), bytes.bytes_.get() + used, capacity - used);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputError(path + ": read failed: " + std::strerror(errno));
    }
    if (n == 0) break;
    used += static_cast<std::size_t>(n);
  }
  bytes.size_ = used;
  return bytes;
}

std::string read_whole_file(const std::string& path) {
  return std::string(read_file_bytes(path).view());
}

}  // namespace delta
