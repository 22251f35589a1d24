// How delta_boot and the program it runs talk (docs/flashing.md), defined
// once for both sides. delta_boot tells the program where it stands through
// environment variables; the program answers with one-line messages on an
// inherited pipe (each under PIPE_BUF bytes, so each arrives whole).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "delta/update/signature.hpp"
#include "fw/update/slots.hpp"

namespace fw_linux::boot {

// The environment delta_boot gives the program.
inline constexpr const char* kEnvFd = "DELTA_BOOT_FD";              // the pipe's write end
inline constexpr const char* kEnvStaging = "DELTA_BOOT_STAGING";    // where a download goes
inline constexpr const char* kEnvCrc = "DELTA_BOOT_CRC";            // this program's CRC-32, hex
inline constexpr const char* kEnvStaged = "DELTA_BOOT_STAGED";      // a staged program's CRC-32
inline constexpr const char* kEnvTrial = "DELTA_BOOT_TRIAL";        // "1": on trial, must confirm
inline constexpr const char* kEnvReverted = "DELTA_BOOT_REVERTED";  // RevertReason, decimal
inline constexpr const char* kEnvPublicKey = "DELTA_BOOT_PUBLIC_KEY";  // 64 hex digits
inline constexpr const char* kEnvCapacity = "DELTA_BOOT_CAPACITY";     // the largest image, bytes

// The program's messages.
enum class Message : std::uint8_t {
  kStaged,   // a valid image is at the staging path
  kStart,    // 0x1F51 = 1: start the staged program on trial
  kReset,    // 0x1F51 = 2: restart the active program
  kClear,    // 0x1F51 = 3: forget the staged program
  kConfirm,  // the trial program passed its checks
};
std::string_view word(Message m);                             // "staged\n", ...
std::optional<Message> parse_message(std::string_view line);  // without the newline

// What the program learns from its environment.
struct Supervision {
  int fd{-1};
  std::string staging_path;
  std::uint32_t running_crc32{0};
  std::optional<std::uint32_t> staged_crc32;  // a program staged before this one started
  bool trial{false};
  fw::update::RevertReason reverted{fw::update::RevertReason::kNone};
  std::optional<delta::update::PublicKey> public_key;
  std::uint32_t capacity_bytes{0};
};

// Reads the environment: nothing when DELTA_BOOT_FD is not set (the
// program runs without delta_boot); ConfigError naming the variable when
// one is malformed.
std::optional<Supervision> supervision_from_environment();

}  // namespace fw_linux::boot
