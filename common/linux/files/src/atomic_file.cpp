#include "delta/atomic_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include "delta/input_error.hpp"

namespace delta {

namespace {

std::string folder_of(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

// The rename is durable once the folder's entry is on disk.
void sync_folder(const std::string& path) {
  const std::string folder = folder_of(path);
  const int fd = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) {
    throw InputError(folder + ": cannot open the folder to flush it: " + std::strerror(errno));
  }
  const int rc = ::fsync(fd);
  const int error = errno;
  ::close(fd);
  if (rc != 0) throw InputError(folder + ": fsync of the folder failed: " + std::strerror(error));
}

// The temporary files being written, for the signal handler: fixed slots
// of fixed size, claimed and released with atomics, so that the handler
// reads them without locks or heap.
constexpr int kTemporarySlots = 16;
constexpr std::size_t kTemporaryPathBytes = 4096;
struct TemporarySlot {
  std::atomic<bool> claimed{false};
  std::atomic<bool> ready{false};
  char path[kTemporaryPathBytes];
};
TemporarySlot g_temporaries[kTemporarySlots];

extern "C" void remove_temporaries_and_reraise(int signal_number) {
  for (TemporarySlot& slot : g_temporaries) {
    if (slot.ready.load()) ::unlink(slot.path);
  }
  ::signal(signal_number, SIG_DFL);
  ::raise(signal_number);
}

}  // namespace

int register_temporary(const std::string& path) {
  if (path.size() >= kTemporaryPathBytes) return -1;
  for (int i = 0; i < kTemporarySlots; ++i) {
    bool expected = false;
    if (!g_temporaries[i].claimed.compare_exchange_strong(expected, true)) continue;
    std::memcpy(g_temporaries[i].path, path.c_str(), path.size() + 1);
    g_temporaries[i].ready.store(true);
    return i;
  }
  return -1;
}

void release_temporary(int slot) {
  if (slot < 0 || slot >= kTemporarySlots) return;
  g_temporaries[slot].ready.store(false);
  g_temporaries[slot].claimed.store(false);
}

void remove_temporaries_on_signals() {
  struct sigaction action {};
  action.sa_handler = remove_temporaries_and_reraise;
  sigemptyset(&action.sa_mask);
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}

void rename_durably(const std::string& from, const std::string& to) {
  if (std::rename(from.c_str(), to.c_str()) != 0) {
    throw InputError(to + ": cannot rename " + from + " into place: " + std::strerror(errno));
  }
  sync_folder(to);
}

AtomicFileWriter::AtomicFileWriter(const std::string& path, mode_t mode)
    : path_(path), mode_(mode) {
  // The temporary's name is registered for the signal handler before the
  // file exists, so that no moment leaves it unregistered; O_EXCL makes
  // it this writer's own.
  static std::atomic<unsigned> counter{0};
  for (int attempt = 0; attempt < 100 && fd_ < 0; ++attempt) {
    release_temporary(slot_);
    temporary_ = path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
    slot_ = register_temporary(temporary_);
    fd_ = ::open(temporary_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600);
    if (fd_ < 0 && errno != EEXIST) break;
  }
  if (fd_ < 0) {
    const std::string reason = std::strerror(errno);
    release_temporary(slot_);
    throw InputError(path + ": cannot create a temporary file beside it: " + reason);
  }
}

AtomicFileWriter::~AtomicFileWriter() {
  if (fd_ >= 0) {
    ::close(fd_);
    ::unlink(temporary_.c_str());
  }
  release_temporary(slot_);
}

void AtomicFileWriter::fail(const char* what) {
  const std::string reason = std::strerror(errno);
  ::close(fd_);
  fd_ = -1;
  ::unlink(temporary_.c_str());
  throw InputError(path_ + ": " + what + ": " + reason);
}

void AtomicFileWriter::write(std::string_view piece) {
  const char* data = piece.data();
  std::size_t left = piece.size();
  while (left > 0) {
    const ssize_t n = ::write(fd_, data, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write failed");
    }
    data += n;
    left -= static_cast<std::size_t>(n);
  }
}

void AtomicFileWriter::commit() {
  if (::fchmod(fd_, mode_) != 0) fail("cannot set permissions");
  if (::fsync(fd_) != 0) fail("fsync failed");
  const int rc = ::close(fd_);
  fd_ = -1;
  if (rc != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(temporary_.c_str());
    throw InputError(path_ + ": close failed: " + reason);
  }
  if (std::rename(temporary_.c_str(), path_.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    ::unlink(temporary_.c_str());
    throw InputError(path_ + ": cannot rename the finished file into place: " + reason);
  }
  sync_folder(path_);
}

void write_file_atomically(const std::string& path, std::string_view content, mode_t mode) {
  AtomicFileWriter w(path, mode);
  w.write(content);
  w.commit();
}

namespace {

// SIGINT and SIGTERM held back while it lives; one that came meanwhile is
// delivered when it ends.
class HeldSignals {
 public:
  HeldSignals() {
    sigset_t held;
    sigemptyset(&held);
    sigaddset(&held, SIGINT);
    sigaddset(&held, SIGTERM);
    ::sigprocmask(SIG_BLOCK, &held, &before_);
  }
  HeldSignals(const HeldSignals&) = delete;
  HeldSignals& operator=(const HeldSignals&) = delete;
  ~HeldSignals() { ::sigprocmask(SIG_SETMASK, &before_, nullptr); }

 private:
  sigset_t before_{};
};

}  // namespace

void commit_together(std::initializer_list<AtomicFileWriter*> writers) {
  const HeldSignals held;
  for (AtomicFileWriter* w : writers) {
    if (w != nullptr) w->commit();
  }
}

void write_files_atomically(
    std::initializer_list<std::pair<const std::string*, std::string_view>> files) {
  // Every temporary written first (an interruption removes them), then all
  // renamed at once.
  std::vector<std::unique_ptr<AtomicFileWriter>> writers;
  for (const auto& [path, content] : files) {
    if (path == nullptr || path->empty()) continue;
    writers.push_back(std::make_unique<AtomicFileWriter>(*path));
    writers.back()->write(content);
  }
  const HeldSignals held;
  for (const auto& w : writers) w->commit();
}

std::string output_path_problem(const std::string& path) {
  if (path.empty()) return "no file name";
  struct stat st {};
  if (::stat(path.c_str(), &st) == 0 && S_ISDIR(st.st_mode)) {
    return "'" + path + "' is a folder; give a file name";
  }
  const std::string folder = folder_of(path);
  if (::stat(folder.c_str(), &st) != 0) {
    return "cannot write '" + path + "': the folder '" + folder + "' " +
           (errno == ENOENT ? "does not exist" : std::strerror(errno)) + " (create it first)";
  }
  if (!S_ISDIR(st.st_mode)) return "cannot write '" + path + "': '" + folder + "' is not a folder";
  if (::access(folder.c_str(), W_OK | X_OK) != 0) {
    return "cannot write '" + path + "': the folder '" + folder + "' is not writable (" +
           std::strerror(errno) + ")";
  }
  return "";
}

std::string partial_log_path(const std::string& path) {
  const auto slash = path.find_last_of('/');
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash) ||
      dot == (slash == std::string::npos ? 0 : slash + 1)) {
    return path + ".partial";
  }
  return path.substr(0, dot) + ".partial" + path.substr(dot);
}

}  // namespace delta
