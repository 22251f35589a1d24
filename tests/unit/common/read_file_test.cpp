#include "delta/read_file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <string>
#include <thread>

#include "delta/input_error.hpp"
#include "scratch_directory.hpp"

namespace {

class ReadFileTest : public ::testing::Test {
 protected:
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

TEST_F(ReadFileTest, ARegularFileIsReadWhole) {
  const std::string text = pattern(100'000);
  const std::string path = write("log.csv", text);
  EXPECT_EQ(delta::read_file_bytes(path).view(), text);
  EXPECT_EQ(delta::read_whole_file(path), text);
}

TEST_F(ReadFileTest, AnEmptyFileIsEmpty) {
  const std::string path = write("empty.csv", "");
  EXPECT_EQ(delta::read_file_bytes(path).view(), "");
}

// A pipe's size is unknown: the buffer grows past its first 64 KiB twice.
TEST_F(ReadFileTest, APipeIsReadToItsEnd) {
  const std::string fifo = dir_.file("pipe");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string text = pattern(200'000);
  std::thread writer([&] { std::ofstream(fifo, std::ios::binary) << text; });
  const delta::FileBytes bytes = delta::read_file_bytes(fifo);
  writer.join();
  EXPECT_EQ(bytes.view(), text);
}

TEST_F(ReadFileTest, AMissingFileIsNamedWithTheSystemsReason) {
  const std::string path = dir_.file("missing.csv");
  try {
    (void)delta::read_file_bytes(path);
    FAIL() << "no error";
  } catch (const delta::InputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": cannot open: No such file or directory");
  }
}

TEST_F(ReadFileTest, AFolderIsRefusedAsAFolder) {
  try {
    (void)delta::read_file_bytes(dir_.file(""));
    FAIL() << "no error";
  } catch (const delta::InputError& e) {
    EXPECT_NE(std::string(e.what()).find(": is a folder, not a file"), std::string::npos)
        << e.what();
  }
}

}  // namespace
