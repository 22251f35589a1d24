#include "child_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

extern char** environ;

namespace hil {

Child Child::spawn(const std::vector<std::string>& argv) {
  int out[2];
  int err[2];
  if (pipe2(out, O_CLOEXEC) != 0 || pipe2(err, O_CLOEXEC) != 0) {
    throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  posix_spawn_file_actions_adddup2(&actions, err[1], 2);
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(out[1]);
  close(err[1]);
  if (rc != 0) {
    close(out[0]);
    close(err[0]);
    throw std::runtime_error("cannot start " + argv[0] + ": " + std::strerror(rc));
  }
  const int pidfd = static_cast<int>(syscall(SYS_pidfd_open, pid, 0));
  if (pidfd < 0) throw std::runtime_error(std::string("pidfd_open: ") + std::strerror(errno));
  fcntl(out[0], F_SETFL, O_NONBLOCK);
  fcntl(err[0], F_SETFL, O_NONBLOCK);
  return Child(pid, pidfd, out[0], err[0]);
}

Child::Child(Child&& o) noexcept
    : pid_(o.pid_),
      pidfd_(o.pidfd_),
      out_fd_(o.out_fd_),
      err_fd_(o.err_fd_),
      out_(std::move(o.out_)),
      err_(std::move(o.err_)),
      status_(o.status_) {
  o.pid_ = o.pidfd_ = o.out_fd_ = o.err_fd_ = -1;
}

Child::~Child() {
  if (pid_ > 0 && !status_) {
    kill(pid_, SIGKILL);
    int st = 0;
    waitpid(pid_, &st, 0);
  }
  for (int fd : {pidfd_, out_fd_, err_fd_}) {
    if (fd >= 0) close(fd);
  }
}

bool Child::pump(std::chrono::milliseconds timeout) {
  pollfd p[3] = {{out_fd_, POLLIN, 0}, {err_fd_, POLLIN, 0}, {pidfd_, POLLIN, 0}};
  const int n = poll(p, 3, static_cast<int>(timeout.count()));
  if (n <= 0) return false;
  char buf[4096];
  for (int i = 0; i < 2; ++i) {
    for (;;) {
      const ssize_t r = read(p[i].fd, buf, sizeof buf);
      if (r <= 0) break;
      (i == 0 ? out_ : err_).append(buf, static_cast<std::size_t>(r));
    }
  }
  if ((p[2].revents & POLLIN) && !status_) {
    int st = 0;
    if (waitpid(pid_, &st, WNOHANG) == pid_) {
      status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
      // Whatever is still in the pipes.
      for (int i = 0; i < 2; ++i) {
        for (;;) {
          const ssize_t r = read(p[i].fd, buf, sizeof buf);
          if (r <= 0) break;
          (i == 0 ? out_ : err_).append(buf, static_cast<std::size_t>(r));
        }
      }
    }
  }
  return true;
}

bool Child::wait_for_output(const std::string& needle, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (out_.find(needle) != std::string::npos || err_.find(needle) != std::string::npos) {
      return true;
    }
    if (status_) return false;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        end - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    pump(left);
  }
}

std::optional<int> Child::wait(std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!status_) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        end - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      kill(pid_, SIGKILL);
      int st = 0;
      waitpid(pid_, &st, 0);
      status_ = 128 + SIGKILL;
      return std::nullopt;
    }
    pump(left);
  }
  return status_;
}

std::optional<int> Child::terminate(std::chrono::milliseconds timeout) {
  if (!status_) kill(pid_, SIGTERM);
  return wait(timeout);
}

}  // namespace hil
