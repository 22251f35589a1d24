#include "host_id/huge_pages.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>

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

// A regressor-sized buffer advised before it is written is backed by huge
// pages wherever the kernel offers them on advice (transparent_hugepage
// "always" or "madvise"); where it offers none, the advice changes nothing.
TEST(HugePagesTest, AnAdvisedBufferIsFaultedInAsHugePagesWhereTheKernelHasThem) {
  const std::string setting = first_line("/sys/kernel/mm/transparent_hugepage/enabled");
  Eigen::MatrixXd buffer(1 << 20, 3);  // 24 MiB, not yet written
  advise_huge_pages(buffer.data(), static_cast<std::size_t>(buffer.size()) * sizeof(double));
  buffer.setConstant(1.0);
  // The advice splits the mapping at the 2 MiB boundaries: ask about the
  // part that holds the buffer's middle.
  const long huge_kib = huge_kib_of_mapping_holding(buffer.data() + buffer.size() / 2);
  ASSERT_GE(huge_kib, 0) << "no mapping holds the buffer in /proc/self/smaps";
  if (setting.empty() || setting.find("[never]") != std::string::npos) {
    EXPECT_EQ(huge_kib, 0) << setting;
  } else {
    EXPECT_GE(huge_kib, 2048) << "transparent_hugepage: " << setting;
  }
  EXPECT_DOUBLE_EQ(buffer.sum(), 3.0 * (1 << 20));
}

// Ranges without a whole 2 MiB block inside are left alone.
TEST(HugePagesTest, SmallAndUnalignedRangesAreAcceptedAsTheyAre) {
  std::vector<double> small(1000, 2.0);
  advise_huge_pages(small.data(), small.size() * sizeof(double));
  advise_huge_pages(small.data() + 1, 0);
  EXPECT_DOUBLE_EQ(small[999], 2.0);
}

}  // namespace
}  // namespace host_id
