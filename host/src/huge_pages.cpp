#include "host_id/huge_pages.hpp"

#include <malloc.h>
#include <sys/mman.h>

#include <array>
#include <cstdint>
#include <mutex>
#include <new>
#include <type_traits>

namespace host_id {

namespace {

constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;

bool from_kernel(std::size_t bytes) {
  return !kBuffersFromOperatorNew && bytes >= kHugePageBufferBytes;
}

std::size_t whole_blocks(std::size_t bytes) {
  return (bytes + kHuge - 1) & ~(kHuge - 1);
}

// Mappings of one or two 2 MiB blocks, kept when freed for the next buffer
// of the same length: a fit frees and takes such buffers again and again
// (filter blocks, labels, residuals), and each fresh one costs the kernel a
// page fault and the clearing of every byte of its blocks. At most
// kKeptBytes in all, so a long log's memory is not held back (its buffers
// are larger and never kept).
class KeptBlocks {
 public:
  static constexpr std::size_t kLargestKept = 2 * kHuge;
  static constexpr std::size_t kKeptBytes = 8 * kHuge;

  // The mapping of exactly `length` bytes kept last, or nullptr.
  void* take(std::size_t length) {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = count_; i-- > 0;) {
      if (blocks_[i].length == length) {
        void* p = blocks_[i].at;
        for (std::size_t k = i; k + 1 < count_; ++k) blocks_[k] = blocks_[k + 1];
        --count_;
        kept_bytes_ -= length;
        return p;
      }
    }
    return nullptr;
  }

  // Every kept mapping back to the kernel.
  void give_back() noexcept {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = 0; i < count_; ++i) munmap(blocks_[i].at, blocks_[i].length);
    count_ = 0;
    kept_bytes_ = 0;
  }

  // True if the mapping is kept (else the caller unmaps it).
  bool keep(void* p, std::size_t length) {
    if (length > kLargestKept) return false;
    const std::lock_guard<std::mutex> lock(mutex_);
    if (count_ == blocks_.size() || kept_bytes_ + length > kKeptBytes) return false;
    blocks_[count_++] = {p, length};
    kept_bytes_ += length;
    return true;
  }

 private:
  struct Block {
    void* at{nullptr};
    std::size_t length{0};
  };
  std::mutex mutex_;
  std::array<Block, 8> blocks_{};
  std::size_t count_{0};
  std::size_t kept_bytes_{0};
};

// Never destroyed (nothing to do): a buffer freed by another static object's
// destructor at exit still finds it.
KeptBlocks kept_blocks;
static_assert(std::is_trivially_destructible_v<KeptBlocks>);

}  // namespace

void advise_huge_pages(void* data, std::size_t bytes) {
  const auto begin = reinterpret_cast<std::uintptr_t>(data);
  const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t last = (begin + bytes) & ~(kHuge - 1);
  if (last <= first) return;
  // Advice only: an error (no THP in this kernel) leaves the buffer as it was.
  (void)madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
}

void keep_freed_memory_for_reuse() {
#if defined(M_MMAP_THRESHOLD) && defined(M_TRIM_THRESHOLD)
  constexpr int kLargestHeapBlock = 32 << 20;  // glibc's upper limit for the threshold
  constexpr int kKeptAtTop = 256 << 20;
  // Advice only: where a knob is refused, malloc keeps its default.
  (void)mallopt(M_MMAP_THRESHOLD, kLargestHeapBlock);
  (void)mallopt(M_TRIM_THRESHOLD, kKeptAtTop);
#endif
}

void return_kept_buffers() noexcept {
  kept_blocks.give_back();
}

void* allocate_buffer(std::size_t bytes) {
  if (!from_kernel(bytes)) return ::operator new(bytes);
  const std::size_t length = whole_blocks(bytes);
  if (void* kept = kept_blocks.take(length)) return kept;
  // One block more than needed, so that an aligned run of blocks lies inside;
  // the unaligned head and the tail go back at once.
  void* mapped =
      mmap(nullptr, length + kHuge, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (mapped == MAP_FAILED) throw std::bad_alloc();
  const auto begin = reinterpret_cast<std::uintptr_t>(mapped);
  const std::uintptr_t aligned = (begin + kHuge - 1) & ~(kHuge - 1);
  if (aligned > begin) munmap(mapped, aligned - begin);
  if (const std::uintptr_t tail = begin + length + kHuge - (aligned + length); tail > 0) {
    munmap(reinterpret_cast<void*>(aligned + length), tail);
  }
  void* out = reinterpret_cast<void*>(aligned);
  (void)madvise(out, length, MADV_HUGEPAGE);  // advice only, as above
  return out;
}

void free_buffer(void* p, std::size_t bytes) noexcept {
  if (p == nullptr) return;
  if (!from_kernel(bytes)) {
    ::operator delete(p);
    return;
  }
  const std::size_t length = whole_blocks(bytes);
  if (!kept_blocks.keep(p, length)) munmap(p, length);
}

const delta::ByteStore kHugePageStore{allocate_buffer, free_buffer};

}  // namespace host_id
