#include "host_id/huge_pages.hpp"

#include <malloc.h>
#include <sys/mman.h>

#include <algorithm>
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

// Freed mappings (whole, aligned 2 MiB blocks), kept for the next buffers
// instead of going back to the kernel: a fit frees and takes buffers of
// megabytes again and again (the file's text, the joint states, filter
// blocks, labels, residuals), and every fresh block costs the kernel a page
// fault and the clearing of its 2 MiB. A buffer takes the smallest kept
// range that holds it, and the rest of that range stays kept; where none
// holds it, it is a new mapping into which the kept ranges move, largest
// first, as many as fit (the kernel moves their pages, not their bytes), so
// that only the rest of it is fresh. A freed range next to a kept one joins
// it. At most kKeptBytes are kept: the part of a freed buffer beyond that
// goes back to the kernel, so a long log's memory is not held back.
class KeptRanges {
 public:
  static constexpr std::size_t kKeptBytes = 32 * kHuge;

  // The start of `length` bytes of kept memory, or nullptr.
  void* take(std::size_t length) {
    const std::lock_guard<std::mutex> lock(mutex_);
    std::size_t best = count_;
    for (std::size_t i = 0; i < count_; ++i) {
      const std::size_t len = ranges_[i].length;
      if (len >= length && (best == count_ || len < ranges_[best].length)) best = i;
    }
    if (best < count_) return take_front(best, length);
    if (count_ > 0) return gather(length);
    return nullptr;
  }

  // Keeps [p, p + length) as far as the limit allows and gives the rest
  // back to the kernel.
  void keep(void* p, std::size_t length) noexcept {
    const std::lock_guard<std::mutex> lock(mutex_);
    const std::size_t kept = std::min(length, kKeptBytes - kept_bytes_);
    if (kept < length) munmap(static_cast<char*>(p) + kept, length - kept);
    if (kept == 0) return;
    if (!join(p, kept)) {
      if (count_ == ranges_.size()) {
        munmap(p, kept);
        return;
      }
      ranges_[count_++] = {static_cast<char*>(p), kept};
    }
    kept_bytes_ += kept;
  }

  // Every kept range back to the kernel.
  void give_back() noexcept {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (std::size_t i = 0; i < count_; ++i) munmap(ranges_[i].at, ranges_[i].length);
    count_ = 0;
    kept_bytes_ = 0;
  }

 private:
  struct Range {
    char* at{nullptr};
    std::size_t length{0};
  };

  void* take_front(std::size_t i, std::size_t length) {
    char* p = ranges_[i].at;
    ranges_[i].at += length;
    ranges_[i].length -= length;
    kept_bytes_ -= length;
    if (ranges_[i].length == 0) remove(i);
    return p;
  }

  // A new aligned mapping of `length` bytes into whose front the kept
  // ranges move, largest first, as many as fit (their pages move, not their
  // bytes); the rest of it is fresh. nullptr where the kernel refuses.
  void* gather(std::size_t length) {
    void* reserved =
        mmap(nullptr, length + kHuge, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (reserved == MAP_FAILED) return nullptr;
    const auto begin = reinterpret_cast<std::uintptr_t>(reserved);
    const std::uintptr_t aligned = (begin + kHuge - 1) & ~(kHuge - 1);
    if (aligned > begin) munmap(reserved, aligned - begin);
    if (const std::uintptr_t tail = begin + length + kHuge - (aligned + length); tail > 0) {
      munmap(reinterpret_cast<void*>(aligned + length), tail);
    }
    char* const out = reinterpret_cast<char*>(aligned);
    std::size_t filled = 0;
    for (std::size_t i = largest_fitting(length); i < count_;
         i = largest_fitting(length - filled)) {
      const Range r = ranges_[i];
      remove(i);
      kept_bytes_ -= r.length;
      if (!move_range(r.at, r.length, out + filled)) {
        munmap(out, length);
        return nullptr;
      }
      filled += r.length;
    }
    (void)madvise(out, length, MADV_HUGEPAGE);  // advice only
    return out;
  }

  // Moves the pages of [from, from + length) over [to, to + length), which
  // is ours: in one piece, or a 2 MiB block at a time where the range spans
  // mappings the kernel keeps apart (two joined ranges it did not merge).
  // A block that will not move goes back to the kernel and fresh memory
  // takes its place (a failed move may have unmapped its destination).
  // False if not even that can be had.
  static bool move_range(char* from, std::size_t length, char* to) {
    const auto moved = [](char* a, std::size_t n, char* b) {
      return mremap(a, n, n, MREMAP_MAYMOVE | MREMAP_FIXED, b) != MAP_FAILED;
    };
    if (moved(from, length, to)) return true;
    for (std::size_t at = 0; at < length; at += kHuge) {
      if (moved(from + at, kHuge, to + at)) continue;
      munmap(from + at, kHuge);
      if (mmap(to + at, kHuge, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS | MAP_FIXED, -1,
               0) == MAP_FAILED) {
        return false;
      }
    }
    return true;
  }

  // The largest kept range of at most `room` bytes, or count_.
  std::size_t largest_fitting(std::size_t room) const {
    std::size_t found = count_;
    for (std::size_t i = 0; i < count_; ++i) {
      if (ranges_[i].length <= room &&
          (found == count_ || ranges_[i].length > ranges_[found].length)) {
        found = i;
      }
    }
    return found;
  }

  // Whether [p, p + length) joined a kept range it borders.
  bool join(void* p, std::size_t length) {
    char* at = static_cast<char*>(p);
    for (std::size_t i = 0; i < count_; ++i) {
      if (ranges_[i].at + ranges_[i].length == at) {
        ranges_[i].length += length;
        return true;
      }
      if (at + length == ranges_[i].at) {
        ranges_[i] = {at, ranges_[i].length + length};
        return true;
      }
    }
    return false;
  }

  void remove(std::size_t i) {
    for (std::size_t k = i; k + 1 < count_; ++k) ranges_[k] = ranges_[k + 1];
    --count_;
  }

  std::mutex mutex_;
  std::array<Range, 32> ranges_{};
  std::size_t count_{0};
  std::size_t kept_bytes_{0};
};

// Never destroyed (nothing to do): a buffer freed by another static object's
// destructor at exit still finds it.
KeptRanges kept_ranges;
static_assert(std::is_trivially_destructible_v<KeptRanges>);

}  // namespace

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
  kept_ranges.give_back();
}

void* allocate_buffer(std::size_t bytes) {
  if (!from_kernel(bytes)) return ::operator new(bytes);
  const std::size_t length = whole_blocks(bytes);
  if (void* kept = kept_ranges.take(length)) return kept;
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
  kept_ranges.keep(p, length);
}

const delta::ByteStore kHugePageStore{allocate_buffer, free_buffer};

}  // namespace host_id
