#include "supervisor.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <sys/syscall.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ostream>

#include "delta/input_error.hpp"
#include "public_key_store.hpp"

extern char** environ;

namespace fw_linux::boot {

namespace up = delta::update;
using fw::update::RevertReason;
using fw::update::SlotState;
using Clock = std::chrono::steady_clock;

namespace {

std::string hex32(std::uint32_t v) {
  char text[16];
  std::snprintf(text, sizeof text, "%08X", v);
  return text;
}

std::string describe_status(int status) {
  if (WIFSIGNALED(status)) {
    return std::string("was killed by signal ") + std::to_string(WTERMSIG(status)) + " (" +
           strsignal(WTERMSIG(status)) + ")";
  }
  return "exited with status " + std::to_string(WEXITSTATUS(status));
}

sigset_t stop_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  return set;
}

}  // namespace

Supervisor::Supervisor(SlotStore& store, fw::update::BootRecord record, SupervisorOptions options,
                       std::ostream& log)
    : store_(store), slots_(record), options_(std::move(options)), log_(log) {
  const sigset_t set = stop_signals();
  sigprocmask(SIG_BLOCK, &set, nullptr);
  signal_fd_ = signalfd(-1, &set, SFD_CLOEXEC | SFD_NONBLOCK);
  if (signal_fd_ < 0) throw delta::InputError(std::string("signalfd: ") + std::strerror(errno));
}

Supervisor::~Supervisor() {
  stop_program();
  if (signal_fd_ >= 0) close(signal_fd_);
}

std::string Supervisor::describe_slot(std::uint8_t slot) const {
  const fw::update::Slot& s = slots_.record().slots[slot];
  return "slot " + std::to_string(slot) + " (version " + up::version_text(s.version) +
         ", CRC-32 0x" + hex32(s.crc32) + ")";
}

void Supervisor::save() {
  store_.save_record(slots_.record());
}

int Supervisor::run() {
  if (!launch()) return kExitNoProgram;
  while (!done_) {
    pollfd fds[3] = {{signal_fd_, POLLIN, 0}, {pipe_read_, POLLIN, 0}, {pidfd_, POLLIN, 0}};
    int timeout_ms = -1;
    if (trial_deadline_) {
      const auto left =
          std::chrono::ceil<std::chrono::milliseconds>(*trial_deadline_ - Clock::now());
      timeout_ms = static_cast<int>(std::max<std::int64_t>(left.count(), 0));
    }
    if (poll(fds, 3, timeout_ms) < 0 && errno != EINTR) {
      throw delta::InputError(std::string("poll: ") + std::strerror(errno));
    }
    if (fds[0].revents != 0) {
      signalfd_siginfo info{};
      if (read(signal_fd_, &info, sizeof info) > 0) {
        log_ << "delta_boot: signal " << info.ssi_signo << ": stopping the program\n";
        const int status = stop_program();
        done_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      continue;
    }
    if (fds[1].revents != 0) read_messages();
    if (fds[2].revents != 0) {
      int status = 0;
      waitpid(child_, &status, 0);
      forget_child();
      on_exit(status);
      continue;
    }
    if (trial_deadline_ && Clock::now() >= *trial_deadline_) {
      log_ << "delta_boot: the program in " << describe_slot(slots_.spare())
           << " did not confirm within " << options_.trial_timeout.count() << " ms\n";
      stop_program();
      trial_failed(RevertReason::kNoConfirmation);
      if (!launch()) return kExitNoProgram;
    }
  }
  return *done_;
}

void Supervisor::read_messages() {
  char buffer[256];
  const ssize_t n = read(pipe_read_, buffer, sizeof buffer);
  if (n <= 0) {
    if (n == 0 || errno != EAGAIN) {  // the program closed its end
      close(pipe_read_);
      pipe_read_ = -1;
    }
    return;
  }
  pending_.append(buffer, static_cast<std::size_t>(n));
  for (std::size_t nl; (nl = pending_.find('\n')) != std::string::npos;) {
    const std::string line = pending_.substr(0, nl);
    pending_.erase(0, nl + 1);
    if (const auto m = parse_message(line)) {
      on_message(*m);
    } else {
      log_ << "delta_boot: ignored an unknown message from the program: '" << line << "'\n";
    }
  }
}

void Supervisor::on_message(Message m) {
  const std::uint8_t spare = slots_.spare();
  switch (m) {
    case Message::kStaged: {
      if (take_key_image()) return;
      if (slots_.begin_download() != fw::update::Refusal::kNone) {
        log_ << "delta_boot: a download during a trial is refused\n";
        std::remove(store_.staging_path().c_str());
        return;
      }
      const SlotImage s = store_.accept_staged(spare);
      slots_.end_download(s.verdict, s.crc32, s.version);
      save();
      if (s.verdict == up::Verdict::kOk) {
        log_ << "delta_boot: staged " << describe_slot(spare) << "\n";
      } else {
        log_ << "delta_boot: refused the downloaded image: " << up::describe(s.verdict) << "\n";
      }
      return;
    }
    case Message::kStart:
      if (slots_.start_trial() != fw::update::Refusal::kNone) {
        log_ << "delta_boot: start refused: no program is staged\n";
        return;
      }
      save();
      log_ << "delta_boot: starting " << describe_slot(spare) << " on trial\n";
      stop_program();
      if (!launch()) done_ = kExitNoProgram;
      return;
    case Message::kReset:
      log_ << "delta_boot: restarting the program\n";
      stop_program();
      if (!launch()) done_ = kExitNoProgram;
      return;
    case Message::kClear:
      if (slots_.clear() == fw::update::Refusal::kNone) {
        save();
        store_.clear(spare);
        log_ << "delta_boot: cleared slot " << int{spare} << "\n";
      }
      return;
    case Message::kConfirm:
      if (slots_.confirm() == fw::update::Refusal::kNone) {
        save();
        trial_deadline_.reset();
        log_ << "delta_boot: confirmed " << describe_slot(slots_.active())
             << "; it is active now\n";
      }
      return;
  }
}

// A staged key image (docs/security.md): signed with the installed key,
// its key takes the installed one's place. The slots' images, which the
// old key vouched for, still start (SlotStore::vouch_for_slots); the
// program restarts, to check downloads with the new key. It never goes
// into a slot. False when the staged download is no key image.
bool Supervisor::take_key_image() {
  up::CheckedImage image;
  try {
    image = up::read_image(store_.staging_path());
  } catch (const delta::InputError&) {
    return false;
  }
  if (!image.header || !image.header->is_public_key()) return false;
  const std::string refusal = key_image_refusal(image);
  std::remove(store_.staging_path().c_str());
  if (!refusal.empty()) {
    log_ << "delta_boot: refused the key image: " << refusal << "\n";
    return true;
  }
  const up::PublicKey next = *up::key_of(image);
  store_.vouch_for_slots();
  retire_public_key(store_.folder(), *options_.public_key);
  install_public_key(store_.folder(), next);
  log_ << "delta_boot: public key replaced (" << fingerprint(*options_.public_key) << "... by "
       << fingerprint(next)
       << "...) by a key image signed with the old key; images must be signed with the new "
          "one, the slots' images still start; restarting the program\n";
  store_.set_key(next);
  options_.public_key = next;
  stop_program();
  if (!launch()) done_ = kExitNoProgram;
  return true;
}

// Why a key image is not taken; "" when it is.
std::string Supervisor::key_image_refusal(const up::CheckedImage& image) const {
  if (!options_.public_key) {
    return "no public key is installed to vouch for it (the first one is installed on the "
           "controller: delta_boot --public-key, docs/security.md)";
  }
  if (slots_.in_trial()) return "a program is on trial";
  const SlotImage s = store_.check(store_.staging_path());
  if (s.verdict != up::Verdict::kOk) {
    return std::string(up::describe(s.verdict)) + " (it must be signed with the installed key)";
  }
  if (!up::key_of(image)) return "its payload is not a 32-byte public key";
  return "";
}

void Supervisor::on_exit(int status) {
  if (slots_.in_trial()) {
    log_ << "delta_boot: the program on trial " << describe_status(status)
         << " before it confirmed\n";
    trial_failed(WIFSIGNALED(status) ? RevertReason::kCrashed : RevertReason::kExited);
    if (!launch()) done_ = kExitNoProgram;
    return;
  }
  log_ << "delta_boot: the program " << describe_status(status) << "\n";
  done_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

void Supervisor::trial_failed(RevertReason why) {
  const std::uint8_t failed = slots_.spare();
  slots_.trial_failed(why);
  save();
  report_revert_ = why;
  trial_deadline_.reset();
  log_ << "delta_boot: rolled back from " << describe_slot(failed) << " to "
       << describe_slot(slots_.active()) << ": " << fw::update::describe(why) << "\n";
}

bool Supervisor::launch() {
  const bool interrupted_trial = slots_.in_trial() && slots_.record().trial_started;
  const fw::update::Launch l = slots_.boot();
  if (interrupted_trial) {
    report_revert_ = RevertReason::kPowerLost;
    log_ << "delta_boot: rolled back to " << describe_slot(slots_.active()) << ": "
         << fw::update::describe(RevertReason::kPowerLost) << "\n";
  }
  save();
  const SlotImage image = store_.extract(l.slot);
  if (image.verdict != up::Verdict::kOk) {
    log_ << "delta_boot: " << store_.slot_path(l.slot)
         << " cannot be started: " << up::describe(image.verdict) << "\n";
    if (!l.trial) return false;
    trial_failed(RevertReason::kNotStartable);
    return launch();
  }
  spawn(image, l.trial);
  if (l.trial) trial_deadline_ = Clock::now() + options_.trial_timeout;
  return true;
}

// The environment the program gets: delta_boot's own, without any
// DELTA_BOOT_ variables, and then this launch's.
std::vector<std::string> Supervisor::environment(const SlotImage& image, bool trial,
                                                 int write_fd) const {
  std::vector<std::string> env;
  for (char** e = environ; *e != nullptr; ++e) {
    if (std::strncmp(*e, "DELTA_BOOT_", 11) != 0) env.emplace_back(*e);
  }
  const auto set = [&](const char* name, const std::string& value) {
    env.push_back(std::string(name) + "=" + value);
  };
  set(kEnvFd, std::to_string(write_fd));
  set(kEnvStaging, store_.staging_path());
  set(kEnvCrc, hex32(image.crc32));
  set(kEnvTrial, trial ? "1" : "0");
  set(kEnvReverted, std::to_string(static_cast<unsigned>(report_revert_)));
  set(kEnvCapacity, std::to_string(options_.capacity_bytes));
  const fw::update::Slot& spare = slots_.record().slots[slots_.spare()];
  if (!trial && spare.state == SlotState::kStaged) set(kEnvStaged, hex32(spare.crc32));
  if (options_.public_key) set(kEnvPublicKey, up::key_text(*options_.public_key).substr(0, 64));
  return env;
}

void Supervisor::spawn(const SlotImage& image, bool trial) {
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) {
    throw delta::InputError(std::string("pipe2: ") + std::strerror(errno));
  }
  std::vector<std::string> env = environment(image, trial, fds[1]);
  std::vector<std::string> args{store_.program_path()};
  args.insert(args.end(), options_.program_arguments.begin(), options_.program_arguments.end());
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::vector<char*> envp;
  for (std::string& e : env) envp.push_back(e.data());
  envp.push_back(nullptr);
  const pid_t pid = fork();
  if (pid < 0) throw delta::InputError(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {  // the child: only async-signal-safe calls until exec
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    fcntl(fds[1], F_SETFD, 0);  // the write end stays open across exec
    execve(argv[0], argv.data(), envp.data());
    _exit(127);
  }
  close(fds[1]);
  if (pipe_read_ >= 0) close(pipe_read_);
  pipe_read_ = fds[0];
  fcntl(pipe_read_, F_SETFL, O_NONBLOCK);
  pending_.clear();
  child_ = pid;
  pidfd_ =
      static_cast<int>(syscall(SYS_pidfd_open, pid, 0));  // glibc 2.36's wrapper lacks extern "C"
  if (pidfd_ < 0) throw delta::InputError(std::string("pidfd_open: ") + std::strerror(errno));
  report_revert_ = RevertReason::kNone;
  log_ << "delta_boot: started " << describe_slot(trial ? slots_.spare() : slots_.active())
       << (trial ? " on trial" : "") << ", pid " << pid << "\n";
}

void Supervisor::forget_child() {
  if (pidfd_ >= 0) close(pidfd_);
  pidfd_ = -1;
  child_ = -1;
}

int Supervisor::stop_program() {
  if (child_ < 0) return 0;
  kill(child_, SIGTERM);
  pollfd p{pidfd_, POLLIN, 0};
  if (poll(&p, 1, static_cast<int>(options_.stop_timeout.count())) <= 0) {
    log_ << "delta_boot: the program did not stop within " << options_.stop_timeout.count()
         << " ms of SIGTERM: SIGKILL\n";
    kill(child_, SIGKILL);
  }
  int status = 0;
  waitpid(child_, &status, 0);
  forget_child();
  return status;
}

}  // namespace fw_linux::boot
