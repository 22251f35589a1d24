#include "host_id/memory.hpp"

#include <gtest/gtest.h>
#include <malloc.h>

#include <cstdlib>
#include <cstring>
#include <thread>

#include "address_sanitizer.hpp"

namespace host_id {
namespace {

// glibc's malloc only: AddressSanitizer's allocator has no such knobs, and
// the test is not built under it (rather than reported as passed).
#if !DELTA_ADDRESS_SANITIZER
// Once asked, malloc serves a block of some MiB from its heap, and keeps it
// when it is freed, so that the next block of that size takes the same,
// already faulted-in memory; by default the block would be a mapping of
// its own, returned to the kernel on free.
TEST(MemoryTest, FreedBlocksAreKeptForTheNextOnceAsked) {
  keep_freed_memory_for_reuse();
  constexpr std::size_t kBytes = std::size_t{8} << 20;
  const struct mallinfo2 before = mallinfo2();
  auto* first = static_cast<char*>(std::malloc(kBytes));
  ASSERT_NE(first, nullptr);
  std::memset(first, 1, kBytes);
  const struct mallinfo2 held = mallinfo2();
  EXPECT_EQ(held.hblkhd, before.hblkhd) << "the block is a mapping of its own";
  // (In use in the heap: its size may not grow where earlier tests in this
  // process left free space there.)
  EXPECT_GE(held.uordblks, before.uordblks + kBytes);
  std::free(first);
  const struct mallinfo2 freed = mallinfo2();
  EXPECT_EQ(freed.arena, held.arena) << "the freed block went back to the kernel";
  EXPECT_GE(freed.fordblks, kBytes);
  auto* second = static_cast<char*>(std::malloc(kBytes));
  ASSERT_NE(second, nullptr);
  EXPECT_EQ(mallinfo2().arena, held.arena) << "the next block took fresh memory";
  std::free(second);
}

// And a thread other than the one that freed a block takes it too (one
// arena for all threads): by default a new thread's blocks come from a heap
// of its own, and a block the main thread freed stays idle. Exits 0 where
// the thread's block fitted in what was freed, as host_id's threads are:
// the knob is set before any thread starts.
[[noreturn]] void another_thread_takes_the_freed_block() {
  keep_freed_memory_for_reuse();
  constexpr std::size_t kBytes = std::size_t{8} << 20;
  auto* first = static_cast<char*>(std::malloc(kBytes));
  if (first == nullptr) std::exit(2);
  std::memset(first, 1, kBytes);
  std::free(first);
  const std::size_t held = mallinfo2().arena;
  std::size_t in_thread = 0;
  std::thread([&] {
    auto* second = static_cast<char*>(std::malloc(kBytes));
    if (second == nullptr) return;
    std::memset(second, 2, kBytes);
    in_thread = mallinfo2().arena;
    std::free(second);
  }).join();
  std::exit(in_thread == held ? 0 : 1);
}

// In a process of its own, started afresh: threads of earlier tests in this
// one leave heaps that a new thread would take first.
TEST(MemoryTest, AnotherThreadTakesTheFreedBlockToo) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_EXIT(another_thread_takes_the_freed_block(), ::testing::ExitedWithCode(0), "");
}
#endif

}  // namespace
}  // namespace host_id
