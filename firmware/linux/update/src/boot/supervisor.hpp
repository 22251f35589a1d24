// delta_boot's supervisor (docs/flashing.md): runs the active slot's
// program, acts on its messages (a staged download, start, reset, clear,
// confirm) and on its end, and rolls a new program back to the previous
// slot when it does not confirm in time, exits or crashes before it
// confirmed. The record is saved before each action, so a power loss
// leaves a slot that boots.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "fw/update/slots.hpp"
#include "fw_linux/boot_protocol.hpp"
#include "slot_store.hpp"

namespace fw_linux::boot {

struct SupervisorOptions {
  std::vector<std::string> program_arguments;  // after the program's name
  std::chrono::milliseconds trial_timeout{30000};
  std::chrono::milliseconds stop_timeout{5000};  // SIGTERM, then SIGKILL
  std::uint32_t capacity_bytes{64u << 20};
  std::optional<delta::update::PublicKey> public_key;  // images must be signed with it
};

// delta_boot's exit codes (docs/flashing.md); otherwise the program's own.
inline constexpr int kExitUsage = 2;
inline constexpr int kExitNoProgram = 7;  // no slot holds a program that starts

class Supervisor {
 public:
  Supervisor(SlotStore& store, fw::update::BootRecord record, SupervisorOptions options,
             std::ostream& log);
  Supervisor(const Supervisor&) = delete;
  Supervisor& operator=(const Supervisor&) = delete;
  ~Supervisor();

  // Runs until the active program ends on its own (its exit status) or
  // delta_boot is told to stop (SIGTERM, SIGINT: the program is stopped
  // first, then its status).
  int run();

 private:
  bool launch();  // what Slots::boot() says; false when nothing starts
  void spawn(const SlotImage& image, bool trial);
  std::vector<std::string> environment(const SlotImage& image, bool trial, int write_fd) const;
  int stop_program();  // its wait status
  void forget_child();
  void read_messages();
  void on_message(Message m);
  bool take_key_image();  // a staged key image, taken or refused; false: none
  std::string key_image_refusal(const delta::update::CheckedImage& image) const;
  void on_exit(int status);  // the program ended by itself
  void trial_failed(fw::update::RevertReason why);
  void save();
  std::string describe_slot(std::uint8_t slot) const;

  SlotStore& store_;
  fw::update::Slots slots_;
  SupervisorOptions options_;
  std::ostream& log_;
  pid_t child_{-1};
  int pidfd_{-1};
  int pipe_read_{-1};
  int signal_fd_{-1};
  std::string pending_;  // a message's start, until its newline
  std::optional<std::chrono::steady_clock::time_point> trial_deadline_;
  fw::update::RevertReason report_revert_{fw::update::RevertReason::kNone};
  std::optional<int> done_;  // the exit code, once run() should return
};

}  // namespace fw_linux::boot
