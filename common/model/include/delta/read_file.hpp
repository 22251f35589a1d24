#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace delta {

// Where a file's bytes are kept: allocate(bytes) gives a buffer of at least
// `bytes` (or throws std::bad_alloc), release(p, bytes) gives it back with
// the same size. The default is operator new; a caller with its own memory
// policy (a large log's text in huge pages, say) passes its own.
struct ByteStore {
  void* (*allocate)(std::size_t bytes);
  void (*release)(void* p, std::size_t bytes) noexcept;
};
extern const ByteStore kOperatorNewStore;

// A file's bytes in a buffer of its size, not cleared before the read
// fills it (for a large log, clearing would be one more pass over memory).
class FileBytes {
 public:
  FileBytes() = default;
  FileBytes(FileBytes&& other) noexcept { swap(other); }
  FileBytes& operator=(FileBytes&& other) noexcept {
    FileBytes(std::move(other)).swap(*this);
    return *this;
  }
  FileBytes(const FileBytes&) = delete;
  FileBytes& operator=(const FileBytes&) = delete;
  ~FileBytes() {
    if (bytes_ != nullptr) store_->release(bytes_, capacity_);
  }
  std::string_view view() const { return {bytes_, size_}; }

 private:
  friend FileBytes read_file_bytes(const std::string& path, const ByteStore& store);
  // Takes a buffer of `capacity` bytes from `store`, `size` of them used.
  FileBytes(char* bytes, std::size_t size, std::size_t capacity, const ByteStore& store)
      : bytes_(bytes), size_(size), capacity_(capacity), store_(&store) {}
  void swap(FileBytes& other) noexcept;
  char* bytes_{nullptr};
  std::size_t size_{0};
  std::size_t capacity_{0};
  const ByteStore* store_{&kOperatorNewStore};
};

// Reads a whole file with one read() into a buffer of the file's size (more
// reads only where the file grows or is not a regular file), the buffer
// from `store`. InputError names the file and the system's reason when it
// cannot be read.
FileBytes read_file_bytes(const std::string& path, const ByteStore& store = kOperatorNewStore);

// The same, as a string (for small files: configuration, JSON).
std::string read_whole_file(const std::string& path);

}  // namespace delta
