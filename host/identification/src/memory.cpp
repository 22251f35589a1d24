#include "host_id/memory.hpp"

#include <malloc.h>

namespace host_id {

void keep_freed_memory_for_reuse() {
#if defined(M_MMAP_THRESHOLD) && defined(M_TRIM_THRESHOLD)
  constexpr int kLargestHeapBlock = 32 << 20;  // glibc's upper limit for the threshold
  constexpr int kKeptAtTop = 256 << 20;
  // Advice only: where a knob is refused, malloc keeps its default.
  (void)mallopt(M_MMAP_THRESHOLD, kLargestHeapBlock);
  (void)mallopt(M_TRIM_THRESHOLD, kKeptAtTop);
#endif
#if defined(M_ARENA_MAX)
  (void)mallopt(M_ARENA_MAX, 1);
#endif
}

}  // namespace host_id
