#include "delta/read_file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "delta/input_error.hpp"
#include "scratch_directory.hpp"

namespace {

// A store that records what it gives and takes back.
struct Ledger {
  std::vector<std::pair<void*, std::size_t>> given, returned;
};
Ledger ledger;

void* counted_allocate(std::size_t bytes) {
  void* p = ::operator new(bytes);
  ledger.given.emplace_back(p, bytes);
  return p;
}

void counted_release(void* p, std::size_t bytes) noexcept {
  ledger.returned.emplace_back(p, bytes);
  ::operator delete(p);
}

const delta::ByteStore kCounted{counted_allocate, counted_release};

class ReadFileTest : public ::testing::Test {
 protected:
  void SetUp() override { ledger = Ledger{}; }
  std::string write(const std::string& name, const std::string& text) {
    const std::string path = dir_.file(name);
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  testsupport::ScratchDirectory dir_{"delta_read_file"};
};

std::string pattern(std::size_t n) {
  std::string s(n, '\0');
  for (std::size_t i = 0; i < n; ++i) s[i] = static_cast<char>('a' + i % 26);
  return s;
}

TEST_F(ReadFileTest, ARegularFileIsReadIntoOneBufferFromTheStoreAndGivenBackWithItsSize) {
  const std::string text = pattern(100'000);
  const std::string path = write("log.csv", text);
  {
    const delta::FileBytes bytes = delta::read_file_bytes(path, kCounted);
    EXPECT_EQ(bytes.view(), text);
    ASSERT_EQ(ledger.given.size(), 1u);
    EXPECT_EQ(ledger.given[0].second, text.size() + 1);  // one byte more shows the end
    EXPECT_TRUE(ledger.returned.empty());
  }
  EXPECT_EQ(ledger.returned, ledger.given);
}

TEST_F(ReadFileTest, APipeGrowsItsBufferAndEveryBufferGoesBackWithItsSize) {
  const std::string fifo = dir_.file("pipe");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string text = pattern(200'000);  // more than 65 536 * 2
  std::thread writer([&] { std::ofstream(fifo, std::ios::binary) << text; });
  {
    const delta::FileBytes bytes = delta::read_file_bytes(fifo, kCounted);
    writer.join();
    EXPECT_EQ(bytes.view(), text);
    ASSERT_EQ(ledger.given.size(), 3u);
    EXPECT_EQ(ledger.given[0].second, 65'536u);
    EXPECT_EQ(ledger.given[1].second, 131'072u);
    EXPECT_EQ(ledger.given[2].second, 262'144u);
    EXPECT_EQ(ledger.returned.size(), 2u);  // the smaller two, once copied
  }
  auto given = ledger.given, returned = ledger.returned;
  std::sort(given.begin(), given.end());
  std::sort(returned.begin(), returned.end());
  EXPECT_EQ(returned, given);
}

TEST_F(ReadFileTest, AMovedBufferIsGivenBackOnceByItsLastOwner) {
  const std::string path = write("a.txt", "abc");
  delta::FileBytes kept;
  {
    delta::FileBytes first = delta::read_file_bytes(path, kCounted);
    kept = std::move(first);
  }
  EXPECT_TRUE(ledger.returned.empty());
  EXPECT_EQ(kept.view(), "abc");
  kept = delta::FileBytes{};
  EXPECT_EQ(ledger.returned, ledger.given);
}

TEST_F(ReadFileTest, AMissingFileIsNamedAndTakesNothingFromTheStore) {
  const std::string path = dir_.file("missing.csv");
  try {
    (void)delta::read_file_bytes(path, kCounted);
    FAIL() << "no error";
  } catch (const delta::InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(path + ": cannot open: ", 0), 0u) << e.what();
  }
  EXPECT_TRUE(ledger.given.empty());
}

TEST_F(ReadFileTest, TheDefaultStoreReadsAsBefore) {
  const std::string path = write("b.txt", "x,y\n1,2\n");
  EXPECT_EQ(delta::read_file_bytes(path).view(), "x,y\n1,2\n");
  EXPECT_EQ(delta::read_whole_file(path), "x,y\n1,2\n");
  EXPECT_TRUE(ledger.given.empty());
}

}  // namespace
