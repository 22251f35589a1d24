#include "host_id/huge_pages.hpp"

#include <malloc.h>
#include <sys/mman.h>

#include <cstdint>
#include <new>

namespace host_id {

namespace {

constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;

bool from_kernel(std::size_t bytes) {
  return !kBuffersFromOperatorNew && bytes >= kHugePageBufferBytes;
}

std::size_t whole_blocks(std::size_t bytes) {
  return (bytes + kHuge - 1) & ~(kHuge - 1);
}

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

void* allocate_buffer(std::size_t bytes) {
  if (!from_kernel(bytes)) return ::operator new(bytes);
  const std::size_t length = whole_blocks(bytes);
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
  munmap(p, whole_blocks(bytes));
}

const delta::ByteStore kHugePageStore{allocate_buffer, free_buffer};

}  // namespace host_id
