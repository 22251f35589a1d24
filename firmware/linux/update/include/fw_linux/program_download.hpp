// CiA 302-3 program download on the controller's node (docs/flashing.md):
// what 0x1F50 (program data), 0x1F51 (program control), 0x1F56 (program
// identification) and 0x1F57 (flash status) do. A download streams into
// the staging file that delta_boot named, checked as it arrives (format,
// length, CRC-32, SHA-256, this node's identity, the signature when
// delta_boot holds a public key); a valid image is renamed into place and
// delta_boot told. Downloads, starts and resets are accepted only while the
// controller is safe to update (no trajectory, drives disabled, brakes
// engaged); without delta_boot there is nowhere to put a program and every
// write is refused.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "delta/can/sdo.hpp"
#include "delta/update/image.hpp"
#include "fw_linux/boot_protocol.hpp"

namespace fw_linux {

// 0x2F00:1, how this program runs.
enum class BootStatus : std::uint8_t {
  kUnsupervised = 0,  // without delta_boot
  kTrial = 1,         // on trial, not confirmed yet
  kConfirmed = 2,     // confirmed (or the active program)
};

class ProgramDownload {
 public:
  ProgramDownload(std::optional<boot::Supervision> supervision, delta::update::Identity identity);
  ~ProgramDownload();
  ProgramDownload(const ProgramDownload&) = delete;
  ProgramDownload& operator=(const ProgramDownload&) = delete;

  // 0x1F50:1, the image's bytes in order (`last` with the final piece).
  delta::can::sdo::AbortCode write(std::uint32_t offset, std::span<const std::uint8_t> data,
                                   bool last, bool safe);
  void abandoned();  // the transfer ended without its last piece
  // 0x1F51:1 = value.
  delta::can::sdo::AbortCode control(std::uint32_t value, bool safe);
  // After every step: a program on trial confirms once the controller is
  // ready (its drives brought up).
  void after_step(bool ready);

  std::uint32_t flash_status() const;   // 0x1F57:1
  std::uint32_t program_crc32() const;  // 0x1F56:1
  std::uint32_t capacity_bytes() const;
  BootStatus boot_status() const;
  fw::update::RevertReason reverted() const;
  // 0x2F00:3: the installed public key's first four bytes, big-endian (the
  // first 8 hex digits of its key file; 0: none), which a key image changes.
  std::uint32_t key_fingerprint() const;

 private:
  delta::can::sdo::AbortCode begin(bool safe);
  delta::can::sdo::AbortCode refuse(delta::update::Verdict v);
  delta::can::sdo::AbortCode finish();
  bool check_header();
  bool flush();
  bool tell(boot::Message m);
  void discard();
  std::string temporary() const;

  std::optional<boot::Supervision> supervision_;
  delta::update::Identity identity_;
  std::optional<delta::update::ImageCheck> check_;
  int fd_{-1};                        // the staging file's temporary, while receiving
  std::vector<std::uint8_t> buffer_;  // allocated once; written out when full
  std::size_t buffered_{0};
  bool header_checked_{false};
  bool staged_{false};
  std::uint32_t staged_crc32_{0};
  bool in_progress_{false};
  delta::update::Verdict verdict_{delta::update::Verdict::kOk};
  std::uint8_t status_code_{0};  // CiA 302-3 error code, 0 none
  bool confirmed_{false};
};

}  // namespace fw_linux
