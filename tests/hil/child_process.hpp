// Child processes for the HIL tests: the real programs (delta_fw,
// delta_drive_emu, host_id), started with posix_spawn, their output read
// through pipes; waits are on the process (pidfd) and on their output lines,
// never on sleeps.
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace hil {

class Child {
 public:
  // Starts argv[0] (a path) with stdout and stderr on pipes.
  static Child spawn(const std::vector<std::string>& argv);
  Child(Child&& o) noexcept;
  Child& operator=(Child&&) = delete;
  Child(const Child&) = delete;
  ~Child();

  // Reads output until a line of stdout or stderr contains `needle`; false
  // on timeout or when the process ended first.
  bool wait_for_output(const std::string& needle, std::chrono::milliseconds timeout);
  // Waits for the exit and returns the exit status (128 + signal when
  // killed); nullopt on timeout (the process is then killed).
  std::optional<int> wait(std::chrono::milliseconds timeout);
  // SIGTERM, then wait.
  std::optional<int> terminate(std::chrono::milliseconds timeout);

  const std::string& out() const { return out_; }
  const std::string& err() const { return err_; }
  int pid() const { return pid_; }

 private:
  Child(int pid, int pidfd, int out_fd, int err_fd)
      : pid_(pid), pidfd_(pidfd), out_fd_(out_fd), err_fd_(err_fd) {}
  // Reads what is available; waits at most `timeout` for something.
  bool pump(std::chrono::milliseconds timeout);
  int pid_{-1};
  int pidfd_{-1};
  int out_fd_{-1};
  int err_fd_{-1};
  std::string out_;
  std::string err_;
  std::optional<int> status_;
};

// A tool run to its end: its exit status (-1: still running at the timeout,
// then killed) and what it wrote.
struct ToolRun {
  int code;
  std::string out;
  std::string err;
};
inline ToolRun run_tool(const std::vector<std::string>& argv, std::chrono::milliseconds timeout) {
  Child c = Child::spawn(argv);
  const int code = c.wait(timeout).value_or(-1);
  return {code, c.out(), c.err()};
}

}  // namespace hil
