// Advice to the kernel about large buffers, and an allocator that places
// them where that advice works.
#pragma once

#include <cstddef>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include "delta/read_file.hpp"

// 1 where AddressSanitizer replaces malloc and operator new (GCC defines
// __SANITIZE_ADDRESS__, Clang has the feature), else 0.
#if defined(__SANITIZE_ADDRESS__)
#define HOST_ID_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define HOST_ID_ADDRESS_SANITIZER 1
#endif
#endif
#ifndef HOST_ID_ADDRESS_SANITIZER
#define HOST_ID_ADDRESS_SANITIZER 0
#endif

namespace host_id {

// Memory for a buffer of `bytes`: from kHugePageBufferBytes on, whole 2 MiB
// blocks from the kernel, aligned to 2 MiB and advised as huge pages (a
// buffer of a few MiB from malloc holds few whole aligned blocks, and its
// first writes fault 4 KiB at a time); below that, operator new. Under
// AddressSanitizer always operator new, so that its checks see the buffer.
// Throws std::bad_alloc when there is no memory. free_buffer keeps freed
// blocks (up to 64 MiB in all; the rest goes back to the kernel) for the
// next allocate_buffer, which gets them as they were left, not cleared: the
// front of the smallest kept range that holds it, or, larger than any, a
// new mapping into which the kept ranges are moved (their pages, not their
// bytes) with only its rest fresh. A fit frees and takes such buffers
// again and again, and every fresh block costs the kernel a fault and the
// clearing of 2 MiB.
inline constexpr std::size_t kHugePageBufferBytes = std::size_t{1} << 20;
inline constexpr bool kBuffersFromOperatorNew = HOST_ID_ADDRESS_SANITIZER != 0;
void* allocate_buffer(std::size_t bytes);
void free_buffer(void* p, std::size_t bytes) noexcept;
// Gives the kept buffers back to the kernel.
void return_kept_buffers() noexcept;

// allocate_buffer and free_buffer as a store for a file's bytes: a log's
// text of a few MiB is then faulted in a 2 MiB page at a time as read()
// fills it, not 4 KiB at a time.
extern const delta::ByteStore kHugePageStore;

// Makes malloc keep the blocks it is given back (up to 32 MiB each, and
// up to 256 MiB at the top of its heap) for the next ones, instead of
// returning each to the kernel and taking fresh pages, which the kernel must
// fault in and clear, for the next. A fit frees the file's text and the
// log's columns just before it allocates the regressor, and the kernel's
// clearing was a tenth of its CPU time. Called once, first thing, by
// programs that read logs; a no-op where the C library has no such knobs.
void keep_freed_memory_for_reuse();

// A standard allocator on allocate_buffer, for the fit's long series.
template <class T>
struct HugePageAllocator {
  using value_type = T;
  HugePageAllocator() = default;
  template <class U>
  HugePageAllocator(const HugePageAllocator<U>&) noexcept {}
  T* allocate(std::size_t n) {
    if (n > static_cast<std::size_t>(-1) / sizeof(T)) throw std::bad_array_new_length();
    return static_cast<T*>(allocate_buffer(n * sizeof(T)));
  }
  void deallocate(T* p, std::size_t n) noexcept { free_buffer(p, n * sizeof(T)); }
  // What resize() and a count constructor add is default-initialised, not
  // value-initialised: a double is left as the memory has it. Every series
  // is written in full before it is read, and zeroing it first was a pass
  // of its own on one thread, which also faulted all its pages in there
  // rather than on the threads that then write it.
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
  friend bool operator==(const HugePageAllocator&, const HugePageAllocator&) { return true; }
};

// A vector of a long series (a sample or a row of the regression per element).
template <class T>
using SeriesVector = std::vector<T, HugePageAllocator<T>>;

}  // namespace host_id
