#include "slot_store.hpp"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string_view>

#include "delta/atomic_file.hpp"
#include "delta/input_error.hpp"
#include "delta/read_file.hpp"
#include "fw_linux/identity.hpp"

namespace fw_linux::boot {

namespace up = delta::update;

namespace {

constexpr const char* kRecordName = "/boot.record";
constexpr const char* kVouchedName = "/vouched.sha256";

std::string hex_digest(const std::string& bytes) {
  const auto d =
      up::sha256(std::span(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()));
  return up::key_text(d).substr(0, 64);
}

}  // namespace

SlotStore::SlotStore(std::string folder, std::optional<up::PublicKey> key)
    : folder_(std::move(folder)), key_(key) {}

std::string SlotStore::slot_path(std::uint8_t slot) const {
  return folder_ + "/slot-" + std::to_string(slot) + ".img";
}

std::optional<fw::update::BootRecord> SlotStore::load_record() const {
  const std::string path = folder_ + kRecordName;
  if (!std::filesystem::exists(path)) return std::nullopt;
  const std::string text = delta::read_whole_file(path);
  fw::update::RecordBytes bytes{};
  fw::update::BootRecord r;
  if (text.size() != bytes.size()) {
    throw delta::InputError(path + ": " + std::to_string(text.size()) +
                            " bytes, a boot record has " + std::to_string(bytes.size()));
  }
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(text[i]);
  if (!fw::update::decode(bytes, r)) {
    throw delta::InputError(path + ": not a valid boot record (magic, CRC-32 or a value)");
  }
  return r;
}

void SlotStore::save_record(const fw::update::BootRecord& r) const {
  fw::update::RecordBytes bytes{};
  fw::update::encode(r, bytes);
  delta::write_file_atomically(
      folder_ + kRecordName,
      std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

SlotImage SlotStore::check(const std::string& image_path) const {
  return check(image_path, false);
}

SlotImage SlotStore::check(const std::string& image_path, bool vouching) const {
  SlotImage s;
  up::CheckedImage image;
  try {
    image = up::read_image(image_path);
  } catch (const delta::InputError&) {
    s.verdict = up::Verdict::kNoValidProgram;
    return s;
  }
  s.verdict = image.verdict;
  if (s.verdict != up::Verdict::kOk) return s;
  const up::ImageHeader& h = *image.header;
  s.verdict = up::check_identity(h, controller_identity(h.version));
  if (s.verdict == up::Verdict::kOk) {
    up::HeaderBytes header{};
    std::copy_n(image.bytes.begin(), header.size(), header.begin());
    s.verdict = up::check_signature(header, h, key_);
  }
  const bool vouched_for =
      vouching &&
      (s.verdict == up::Verdict::kBadSignature || s.verdict == up::Verdict::kUnsigned) &&
      vouched(std::string(image.bytes.begin(), image.bytes.end()));
  if (vouched_for) s.verdict = up::Verdict::kOk;
  s.crc32 = h.payload_crc32;
  s.version = h.version;
  return s;
}

bool SlotStore::vouched(const std::string& bytes) const {
  const std::string path = folder_ + kVouchedName;
  if (!std::filesystem::exists(path)) return false;
  return delta::read_whole_file(path).find(hex_digest(bytes)) != std::string::npos;
}

void SlotStore::vouch_for_slots() const {
  const std::string path = folder_ + kVouchedName;
  std::string list = std::filesystem::exists(path) ? delta::read_whole_file(path) : "";
  for (std::uint8_t slot = 0; slot < 2; ++slot) {
    if (!std::filesystem::exists(slot_path(slot)) ||
        check(slot_path(slot), true).verdict != up::Verdict::kOk)
      continue;
    list += hex_digest(delta::read_whole_file(slot_path(slot))) + "\n";
  }
  delta::write_file_atomically(path, list, 0644);
}

SlotImage SlotStore::accept_staged(std::uint8_t slot) const {
  const SlotImage s = check(staging_path());
  if (s.verdict != up::Verdict::kOk) {
    std::remove(staging_path().c_str());
    return s;
  }
  delta::rename_durably(staging_path(), slot_path(slot));
  return s;
}

SlotImage SlotStore::install(const std::string& image_path, std::uint8_t slot) const {
  if (const auto h = up::read_image(image_path).header; h && h->is_public_key()) {
    throw delta::InputError(image_path +
                            " is a key image, not a program: it is flashed to replace the "
                            "installed key (docs/security.md)");
  }
  const SlotImage s = check(image_path);
  if (s.verdict != up::Verdict::kOk) return s;
  delta::write_file_atomically(slot_path(slot), delta::read_whole_file(image_path));
  return s;
}

void SlotStore::clear(std::uint8_t slot) const {
  std::remove(slot_path(slot).c_str());
}

SlotImage SlotStore::extract(std::uint8_t slot) const {
  const SlotImage s = check(slot_path(slot), true);
  if (s.verdict != up::Verdict::kOk) return s;
  const std::string bytes = delta::read_whole_file(slot_path(slot));
  delta::write_file_atomically(program_path(), std::string_view(bytes).substr(up::kHeaderBytes),
                               0755);
  return s;
}

}  // namespace fw_linux::boot
