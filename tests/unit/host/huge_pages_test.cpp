#include "host_id/huge_pages.hpp"

#include <gtest/gtest.h>
#include <malloc.h>
#include <sys/mman.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "scratch_directory.hpp"

namespace host_id {
namespace {

std::string first_line(const char* path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  return line;
}

// The AnonHugePages (kB) of the mapping of /proc/self/smaps that holds p.
long huge_kib_of_mapping_holding(const void* p) {
  const auto at = reinterpret_cast<std::uintptr_t>(p);
  std::ifstream smaps("/proc/self/smaps");
  std::string line;
  bool inside = false;
  while (std::getline(smaps, line)) {
    std::uintptr_t begin = 0, end = 0;
    char dash = 0;
    std::istringstream range(line);
    if (range >> std::hex >> begin >> dash >> end && dash == '-') {
      inside = begin <= at && at < end;
      continue;
    }
    if (inside && line.rfind("AnonHugePages:", 0) == 0) {
      return std::stol(line.substr(line.find(':') + 1));
    }
  }
  return -1;
}

// A series of 3 MiB starts on a 2 MiB boundary, is backed by huge pages
// where the kernel offers them on advice, and grows, shrinks and is freed
// as any vector; a small one comes from operator new.
TEST(HugePagesTest, ALongSeriesLiesOnWholeHugePages) {
  const std::string setting = first_line("/sys/kernel/mm/transparent_hugepage/enabled");
  SeriesVector<double> series(3 * (std::size_t{1} << 17), 1.5);  // 3 MiB
  const auto at = reinterpret_cast<std::uintptr_t>(series.data());
  if (!kBuffersFromOperatorNew) {
    EXPECT_EQ(at % (std::uintptr_t{2} << 20), 0u);
    const long huge_kib = huge_kib_of_mapping_holding(series.data());
    if (setting.empty() || setting.find("[never]") != std::string::npos) {
      EXPECT_EQ(huge_kib, 0) << setting;
    } else {
      EXPECT_GE(huge_kib, 2048) << "transparent_hugepage: " << setting;
    }
  }
  for (int k = 0; k < 100000; ++k) series.push_back(2.5);  // a reallocation
  EXPECT_DOUBLE_EQ(series.front(), 1.5);
  EXPECT_DOUBLE_EQ(series.back(), 2.5);
  EXPECT_EQ(series.size(), 3 * (std::size_t{1} << 17) + 100000);
  series.resize(10);
  series.shrink_to_fit();  // below the threshold: operator new
  EXPECT_DOUBLE_EQ(series[9], 1.5);
  SeriesVector<unsigned char> bytes(100, 7);
  EXPECT_EQ(bytes[99], 7);
}

// A log's text of some MiB is read onto whole huge pages (where the kernel
// offers them on advice), as its bytes arrive, and given back whole.
TEST(HugePagesTest, ALogsTextIsReadOntoHugePages) {
  const std::string setting = first_line("/sys/kernel/mm/transparent_hugepage/enabled");
  const testsupport::ScratchDirectory dir("delta_huge_text");
  const std::string path = dir.file("log.csv");
  const std::string text(3 << 20, 'x');
  std::ofstream(path, std::ios::binary) << text;
  {
    const delta::FileBytes bytes = delta::read_file_bytes(path, kHugePageStore);
    EXPECT_EQ(bytes.view(), text);
    if (!kBuffersFromOperatorNew) {
      EXPECT_EQ(reinterpret_cast<std::uintptr_t>(bytes.view().data()) % (std::uintptr_t{2} << 20),
                0u);
      const long huge_kib = huge_kib_of_mapping_holding(bytes.view().data());
      if (setting.empty() || setting.find("[never]") != std::string::npos) {
        EXPECT_EQ(huge_kib, 0) << setting;
      } else {
        EXPECT_GE(huge_kib, 2048) << "transparent_hugepage: " << setting;
      }
    }
  }
}

// What cannot be had is std::bad_alloc (or bad_array_new_length for a size
// whose bytes do not fit in size_t), as from operator new.
TEST(HugePagesTest, AnImpossibleSeriesThrowsBadAlloc) {
  HugePageAllocator<double> allocator;
  EXPECT_THROW((void)allocator.allocate(std::size_t{1} << 62), std::bad_array_new_length);
  // (AddressSanitizer's operator new reports a size this large and stops.)
  if (!kBuffersFromOperatorNew) {
    EXPECT_THROW((void)allocator.allocate(std::size_t{1} << 58), std::bad_alloc);
  }
}

// glibc's malloc only: AddressSanitizer's allocator has no such knobs, and
// the test is not built under it (rather than reported as passed).
#if !HOST_ID_ADDRESS_SANITIZER
// Once asked, malloc serves a block of some MiB from its heap, and keeps it
// when it is freed, so that the next block of that size takes the same,
// already faulted-in memory; by default the block would be a mapping of
// its own, returned to the kernel on free.
TEST(HugePagesTest, FreedBlocksAreKeptForTheNextOnceAsked) {
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
#endif

// Kernel buffers only (under AddressSanitizer they come from operator new,
// and these tests are not built rather than reported as passed).
#if !HOST_ID_ADDRESS_SANITIZER
// Whether [p, p + bytes) is mapped in this process.
bool mapped(void* p, std::size_t bytes) {
  std::vector<unsigned char> pages(bytes / 4096 + 1);
  return mincore(p, bytes, pages.data()) == 0;
}

constexpr std::size_t kBlock = std::size_t{2} << 20;

// Fills [p, p + bytes) with the byte v.
void paint(void* p, std::size_t bytes, unsigned char v) {
  std::memset(p, v, bytes);
}

// Whether every byte of [p, p + bytes) is v.
bool painted(const void* p, std::size_t bytes, unsigned char v) {
  const auto* c = static_cast<const unsigned char*>(p);
  for (std::size_t i = 0; i < bytes; ++i) {
    if (c[i] != v) return false;
  }
  return true;
}

// A freed buffer goes to the next buffer it can hold, as it was left.
TEST(HugePagesTest, AFreedBufferIsTheNextThatFitsAsItWasLeft) {
  return_kept_buffers();
  constexpr std::size_t kBytes = 3 << 20;  // two blocks
  auto* first = static_cast<char*>(allocate_buffer(kBytes));
  paint(first, kBytes, 7);
  free_buffer(first, kBytes);
  EXPECT_TRUE(mapped(first, kBytes)) << "not kept";
  auto* again = static_cast<char*>(allocate_buffer(kBytes - 12345));  // the same two blocks
  EXPECT_EQ(again, first);
  EXPECT_TRUE(painted(again, kBytes - 12345, 7)) << "not as it was left";
  auto* other = static_cast<char*>(allocate_buffer(kBytes));  // none kept now: fresh
  EXPECT_NE(other, first);
  EXPECT_TRUE(painted(other, kBytes, 0));
  free_buffer(other, kBytes);
  free_buffer(again, kBytes - 12345);
  return_kept_buffers();
  EXPECT_FALSE(mapped(first, kBytes)) << "return_kept_buffers kept it";
  EXPECT_FALSE(mapped(other, kBytes)) << "return_kept_buffers kept it";
}

// A large freed buffer serves smaller ones from its front, and what is left
// of it stays kept for the next.
TEST(HugePagesTest, ALargeFreedBufferIsSharedOutToSmallerOnes) {
  return_kept_buffers();
  auto* large = static_cast<char*>(allocate_buffer(5 * kBlock));
  for (std::size_t b = 0; b < 5; ++b)
    paint(large + b * kBlock, kBlock, static_cast<unsigned char>(b + 1));
  free_buffer(large, 5 * kBlock);
  auto* a = static_cast<char*>(allocate_buffer(3 << 20));  // two blocks
  auto* b = static_cast<char*>(allocate_buffer(2 * kBlock));
  auto* c = static_cast<char*>(allocate_buffer(kBlock));
  EXPECT_EQ(a, large);
  EXPECT_EQ(b, large + 2 * kBlock);
  EXPECT_EQ(c, large + 4 * kBlock);
  EXPECT_TRUE(painted(b, kBlock, 3));
  EXPECT_TRUE(painted(c, kBlock, 5));
  auto* d = static_cast<char*>(allocate_buffer(kBlock));  // nothing left: fresh
  EXPECT_TRUE(painted(d, kBlock, 0));
  free_buffer(a, 3 << 20);
  free_buffer(b, 2 * kBlock);
  free_buffer(c, kBlock);
  free_buffer(d, kBlock);
  return_kept_buffers();
  EXPECT_FALSE(mapped(large, 5 * kBlock));
}

// A buffer larger than any kept one is a new mapping into whose front the
// kept ones move, largest first, with what they held; the rest is fresh,
// and the kept ones are no longer where they were.
TEST(HugePagesTest, ABufferLargerThanAnyKeptOneGathersThem) {
  return_kept_buffers();
  auto* two = static_cast<char*>(allocate_buffer(2 * kBlock));
  auto* one = static_cast<char*>(allocate_buffer(kBlock));
  paint(two, 2 * kBlock, 9);
  paint(one, kBlock, 4);
  free_buffer(one, kBlock);
  free_buffer(two, 2 * kBlock);
  auto* gathered = static_cast<char*>(allocate_buffer(5 * kBlock));
  EXPECT_EQ(reinterpret_cast<std::uintptr_t>(gathered) % kBlock, 0u) << "not aligned";
  EXPECT_TRUE(painted(gathered, 2 * kBlock, 9));
  EXPECT_TRUE(painted(gathered + 2 * kBlock, kBlock, 4));
  EXPECT_TRUE(painted(gathered + 3 * kBlock, 2 * kBlock, 0));
  EXPECT_FALSE(mapped(two, 2 * kBlock)) << "moved, yet still mapped where it was";
  EXPECT_FALSE(mapped(one, kBlock)) << "moved, yet still mapped where it was";
  paint(gathered, 5 * kBlock, 1);  // writable throughout
  free_buffer(gathered, 5 * kBlock);
  return_kept_buffers();
}

// A kept range that spans two mappings (two joined ranges the kernel keeps
// apart: here one buffer whose halves were advised differently) still
// moves into a larger buffer with what it held. Older kernels refuse
// to move it in one piece, and it goes a block at a time; newer ones may
// move it whole.
TEST(HugePagesTest, AKeptRangeOverTwoMappingsStillMoves) {
  return_kept_buffers();
  auto* two = static_cast<char*>(allocate_buffer(2 * kBlock));
  paint(two, kBlock, 3);
  paint(two + kBlock, kBlock, 5);
  ASSERT_EQ(madvise(two + kBlock, kBlock, MADV_NOHUGEPAGE), 0);  // its own mapping now
  free_buffer(two, 2 * kBlock);
  auto* larger = static_cast<char*>(allocate_buffer(3 * kBlock));
  EXPECT_TRUE(painted(larger, kBlock, 3));
  EXPECT_TRUE(painted(larger + kBlock, kBlock, 5));
  EXPECT_TRUE(painted(larger + 2 * kBlock, kBlock, 0));
  EXPECT_FALSE(mapped(two, 2 * kBlock));
  paint(larger, 3 * kBlock, 1);  // writable throughout
  free_buffer(larger, 3 * kBlock);
  return_kept_buffers();
}

// At most 64 MiB are kept: of twenty freed buffers of 4 MiB, the first
// sixteen stay mapped for the next and the other four go back to the kernel.
TEST(HugePagesTest, AtMostSixtyFourMiBAreKept) {
  return_kept_buffers();
  constexpr std::size_t kBytes = 2 * kBlock;
  std::vector<void*> buffers;
  for (int i = 0; i < 20; ++i) buffers.push_back(allocate_buffer(kBytes));
  for (void* b : buffers) free_buffer(b, kBytes);
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    EXPECT_EQ(mapped(buffers[i], kBytes), i < 16) << "buffer " << i;
  }
  return_kept_buffers();
  for (void* b : buffers) EXPECT_FALSE(mapped(b, kBytes));
}

// The part of a freed buffer beyond the limit goes back to the kernel, and
// its front is kept.
TEST(HugePagesTest, AFreedBufferPastTheLimitKeepsOnlyItsFront) {
  return_kept_buffers();
  auto* most = allocate_buffer(31 * kBlock);
  auto* last = static_cast<char*>(allocate_buffer(3 * kBlock));
  free_buffer(most, 31 * kBlock);
  free_buffer(last, 3 * kBlock);
  EXPECT_TRUE(mapped(last, kBlock));
  EXPECT_FALSE(mapped(last + kBlock, kBlock));
  EXPECT_FALSE(mapped(last + 2 * kBlock, kBlock));
  return_kept_buffers();
  EXPECT_FALSE(mapped(last, kBlock));
}
#endif

}  // namespace
}  // namespace host_id
