// Files written atomically (delta/atomic_file.hpp): what a crash, a failure
// or a Ctrl-C leaves behind.
#include "delta/atomic_file.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>

#include "delta/input_error.hpp"
#include "scratch_directory.hpp"

namespace {

namespace fs = std::filesystem;

// The number of files in `dir`.
std::size_t files_in(const std::string& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir)) ++n;
  return n;
}

TEST(AtomicFileTest, AWrittenFileLeavesNoTemporary) {
  const testsupport::ScratchDirectory dir("delta_atomic");
  delta::write_file_atomically(dir.file("out.csv"), "t,q1\n");
  std::ifstream in(dir.file("out.csv"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, "t,q1\n");
  EXPECT_EQ(files_in(dir.path()), 1u);
}

// Written piece by piece: the old file stays until commit(); a writer that
// ends without commit() (an error, an exception) leaves the old file and no
// temporary; a Ctrl-C halfway removes its temporary.
TEST(AtomicFileTest, AStreamedFileAppearsWholeOnCommitAndNeverHalfWritten) {
  const testsupport::ScratchDirectory dir("delta_atomic_stream");
  const std::string path = dir.file("log.csv");
  delta::write_file_atomically(path, "old\n");
  const auto text = [&] {
    std::ifstream in(path);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  };
  {
    delta::AtomicFileWriter w(path);
    w.write("t,q1\n");
    w.write("0,1\n");
    EXPECT_EQ(text(), "old\n");
    EXPECT_EQ(files_in(dir.path()), 2u);  // the old file and the temporary
    w.commit();
  }
  EXPECT_EQ(text(), "t,q1\n0,1\n");
  EXPECT_EQ(files_in(dir.path()), 1u);
  {
    delta::AtomicFileWriter abandoned(path);
    abandoned.write("half");
  }
  EXPECT_EQ(text(), "t,q1\n0,1\n");
  EXPECT_EQ(files_in(dir.path()), 1u);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    delta::remove_temporaries_on_signals();
    delta::AtomicFileWriter w(dir.file("interrupted.csv"));
    w.write("half a log");
    ::raise(SIGINT);
    ::_exit(0);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  EXPECT_TRUE(WIFSIGNALED(status));
  EXPECT_EQ(files_in(dir.path()), 1u);
  EXPECT_THROW(delta::AtomicFileWriter(dir.file("missing/x.csv")), delta::InputError);
}

// In a child process that asked for it: a temporary file registered when
// SIGINT (or SIGTERM) comes is removed, and the process still ends by the
// signal; a file whose registration was released stays.
void interrupted_while_writing(int signal_number) {
  const testsupport::ScratchDirectory dir("delta_atomic_signal");
  const std::string pending = dir.file("out.csv.tmp.1"), finished = dir.file("kept.csv.tmp.2");
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    delta::remove_temporaries_on_signals();
    std::ofstream(pending) << "half a log";
    std::ofstream(finished) << "a whole one";
    delta::register_temporary(pending);
    delta::release_temporary(delta::register_temporary(finished));
    ::raise(signal_number);
    ::_exit(0);  // not reached: the signal ends the process
  }
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the child exited with " << WEXITSTATUS(status);
  EXPECT_EQ(WTERMSIG(status), signal_number);
  EXPECT_FALSE(fs::exists(pending));
  EXPECT_TRUE(fs::exists(finished));
}

TEST(AtomicFileTest, CtrlCRemovesTheTemporaryBeingWritten) {
  interrupted_while_writing(SIGINT);
}

TEST(AtomicFileTest, SigtermRemovesTheTemporaryBeingWritten) {
  interrupted_while_writing(SIGTERM);
}

}  // namespace
