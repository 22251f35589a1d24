// delta_boot's files in its state folder (docs/flashing.md), each written
// to a temporary, flushed and renamed, so that a power loss leaves the old
// file or the new one:
//
//   boot.record    the slots' record (fw::update::BootRecord, 36 bytes)
//   slot-0.img     the image in slot 0 (header and program)
//   slot-1.img     the image in slot 1
//   incoming.img   where the running program puts a download (staging)
//   program        the program of the slot that runs, extracted
//   vouched.sha256 the SHA-256 of each slot image a replaced key had
//                  vouched for when a key image replaced it: they start
#pragma once

#include <optional>
#include <string>

#include "delta/update/image_file.hpp"
#include "fw/update/slots.hpp"

namespace fw_linux::boot {

// What a checked image holds; verdict kOk or why it was refused.
struct SlotImage {
  delta::update::Verdict verdict{delta::update::Verdict::kOk};
  std::uint32_t crc32{0};
  delta::update::Version version{};
};

class SlotStore {
 public:
  SlotStore(std::string folder, std::optional<delta::update::PublicKey> key);

  const std::string& folder() const { return folder_; }
  std::string staging_path() const { return folder_ + "/incoming.img"; }
  std::string program_path() const { return folder_ + "/program"; }
  std::string slot_path(std::uint8_t slot) const;

  // The record; nothing when the folder has none yet. delta::InputError
  // when it exists and is unreadable or corrupt (wrong magic, CRC, value).
  std::optional<fw::update::BootRecord> load_record() const;
  void save_record(const fw::update::BootRecord& r) const;

  // Checks an image file as the controller would: format, length, CRC-32,
  // SHA-256, this controller's vendor and product, the signature when a
  // key is configured.
  SlotImage check(const std::string& image_path) const;
  // The key images are checked with from now on (a key image's).
  void set_key(const delta::update::PublicKey& key) { key_ = key; }
  // Before a key image replaces the key: the slots' images that check out
  // with the old one are recorded as vouched for, so that they still start.
  void vouch_for_slots() const;
  // Checks the staged download and moves it into `slot`.
  SlotImage accept_staged(std::uint8_t slot) const;
  // Copies an image file into `slot` (a first installation).
  SlotImage install(const std::string& image_path, std::uint8_t slot) const;
  void clear(std::uint8_t slot) const;
  // Checks the slot's image again and writes its program where it runs.
  SlotImage extract(std::uint8_t slot) const;

 private:
  // With `vouching`, an image a replaced key vouched for passes too (a
  // slot's, at start; never a download).
  SlotImage check(const std::string& image_path, bool vouching) const;
  bool vouched(const std::string& image_bytes) const;

  std::string folder_;
  std::optional<delta::update::PublicKey> key_;
};

}  // namespace fw_linux::boot
