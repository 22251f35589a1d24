#include "fw_linux/program_download.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "delta/atomic_file.hpp"
#include "delta/input_error.hpp"
#include "delta/update/image_file.hpp"

namespace fw_linux {

namespace sdo = delta::can::sdo;
namespace up = delta::update;

namespace {

constexpr std::size_t kBufferBytes = 64 * 1024;

// CiA 302-3's flash status codes (0x1F57 bits 1-7) that are not a verdict
// on the image itself.
constexpr std::uint8_t kStatusNoValidProgram = 1;
constexpr std::uint8_t kStatusNotCleared = 4;
constexpr std::uint8_t kStatusSecured = 7;

}  // namespace

ProgramDownload::ProgramDownload(std::optional<boot::Supervision> supervision,
                                 up::Identity identity)
    : supervision_(std::move(supervision)), identity_(identity), buffer_(kBufferBytes) {
  if (supervision_ && supervision_->staged_crc32) {
    staged_ = true;
    staged_crc32_ = *supervision_->staged_crc32;
  }
}

ProgramDownload::~ProgramDownload() {
  discard();
}

std::string ProgramDownload::temporary() const {
  return supervision_->staging_path + ".part";
}

sdo::AbortCode ProgramDownload::write(std::uint32_t offset, std::span<const std::uint8_t> data,
                                      bool last, bool safe) {
  if (offset == 0) {
    if (const sdo::AbortCode refused = begin(safe)) return refused;
  } else if (!in_progress_) {
    return sdo::kAbortGeneral;  // the server keeps pieces in order: not reached
  }
  if (!check_->add(data)) return refuse(check_->verdict());
  if (!header_checked_ && check_->header_valid() && !check_header()) return refuse(verdict_);
  std::size_t at = 0;
  while (at < data.size()) {
    const std::size_t n = std::min(data.size() - at, buffer_.size() - buffered_);
    std::memcpy(buffer_.data() + buffered_, data.data() + at, n);
    buffered_ += n;
    at += n;
    if (buffered_ == buffer_.size() && !flush()) return refuse(up::Verdict::kWriteError);
  }
  return last ? finish() : sdo::kNoAbort;
}

sdo::AbortCode ProgramDownload::begin(bool safe) {
  if (!supervision_) return sdo::kAbortCannotStore;
  status_code_ = 0;
  verdict_ = up::Verdict::kOk;
  if (!safe || boot_status() == BootStatus::kTrial) {
    status_code_ = kStatusSecured;
    return sdo::kAbortDeviceState;
  }
  if (staged_) {
    status_code_ = kStatusNotCleared;
    return sdo::kAbortDeviceState;
  }
  discard();
  fd_ = ::open(temporary().c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) return refuse(up::Verdict::kWriteError);
  check_.emplace(capacity_bytes());
  header_checked_ = false;
  buffered_ = 0;
  in_progress_ = true;
  return sdo::kNoAbort;
}

// Once the header is in: for this node, and signed as this node requires.
bool ProgramDownload::check_header() {
  header_checked_ = true;
  verdict_ = up::check_identity(check_->header(), identity_);
  if (verdict_ == up::Verdict::kOk && check_->header().is_public_key() &&
      !supervision_->public_key) {
    verdict_ = up::Verdict::kNoKeyToVouch;  // a key image replaces a key, signed with it
  }
  if (verdict_ == up::Verdict::kOk) {
    verdict_ =
        up::check_signature(check_->header_bytes(), check_->header(), supervision_->public_key);
  }
  return verdict_ == up::Verdict::kOk;
}

bool ProgramDownload::flush() {
  std::size_t at = 0;
  while (at < buffered_) {
    const ssize_t n = ::write(fd_, buffer_.data() + at, buffered_ - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    at += static_cast<std::size_t>(n);
  }
  buffered_ = 0;
  return true;
}

sdo::AbortCode ProgramDownload::finish() {
  const bool written = flush() && ::fsync(fd_) == 0;
  const bool closed = ::close(fd_) == 0;
  fd_ = -1;
  const up::Verdict v = check_->finish();
  if (v != up::Verdict::kOk) return refuse(v);
  if (!written || !closed) return refuse(up::Verdict::kWriteError);
  try {
    delta::rename_durably(temporary(), supervision_->staging_path);
  } catch (const delta::InputError&) {
    return refuse(up::Verdict::kWriteError);
  }
  if (!tell(boot::Message::kStaged)) return refuse(up::Verdict::kWriteError);
  staged_ = true;
  staged_crc32_ = check_->header().payload_crc32;
  in_progress_ = false;
  check_.reset();
  return sdo::kNoAbort;
}

sdo::AbortCode ProgramDownload::refuse(up::Verdict v) {
  verdict_ = v;
  status_code_ = up::cia302_error_code(v);
  discard();
  return sdo::kAbortCannotStore;
}

void ProgramDownload::discard() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (in_progress_) ::unlink(temporary().c_str());
  in_progress_ = false;
  check_.reset();
}

void ProgramDownload::abandoned() {
  if (!in_progress_) return;
  discard();
  verdict_ = up::Verdict::kInterrupted;
  status_code_ = up::cia302_error_code(verdict_);
}

sdo::AbortCode ProgramDownload::control(std::uint32_t value, bool safe) {
  if (!supervision_) return sdo::kAbortCannotStore;
  if (value > 3) return sdo::kAbortValueRange;
  if (in_progress_ || !safe || (value != 2 && boot_status() == BootStatus::kTrial)) {
    return sdo::kAbortDeviceState;
  }
  switch (value) {
    case 0:  // stop: this controller runs nothing while it is safe to update
      return sdo::kNoAbort;
    case 1:
      if (!staged_) {
        verdict_ = up::Verdict::kNoValidProgram;
        status_code_ = kStatusNoValidProgram;
        return sdo::kAbortDeviceState;
      }
      return tell(boot::Message::kStart) ? sdo::kNoAbort : sdo::kAbortCannotStore;
    case 2:
      return tell(boot::Message::kReset) ? sdo::kNoAbort : sdo::kAbortCannotStore;
    default:
      if (!tell(boot::Message::kClear)) return sdo::kAbortCannotStore;
      staged_ = false;
      status_code_ = 0;
      verdict_ = up::Verdict::kOk;
      return sdo::kNoAbort;
  }
}

void ProgramDownload::after_step(bool ready) {
  if (ready && boot_status() == BootStatus::kTrial && tell(boot::Message::kConfirm)) {
    confirmed_ = true;
  }
}

bool ProgramDownload::tell(boot::Message m) {
  const std::string_view w = boot::word(m);
  for (;;) {
    const ssize_t n = ::write(supervision_->fd, w.data(), w.size());
    if (n < 0 && errno == EINTR) continue;
    return n == static_cast<ssize_t>(w.size());
  }
}

std::uint32_t ProgramDownload::flash_status() const {
  return (in_progress_ ? 1u : 0u) | (std::uint32_t{status_code_} << 1) |
         (std::uint32_t{static_cast<std::uint8_t>(verdict_)} << 8);
}

std::uint32_t ProgramDownload::program_crc32() const {
  if (staged_) return staged_crc32_;
  return supervision_ ? supervision_->running_crc32 : 0;
}

// Without delta_boot any size gets as far as the refusal that says why.
std::uint32_t ProgramDownload::capacity_bytes() const {
  return supervision_ ? supervision_->capacity_bytes : 0xFFFFFFFF;
}

BootStatus ProgramDownload::boot_status() const {
  if (!supervision_) return BootStatus::kUnsupervised;
  return supervision_->trial && !confirmed_ ? BootStatus::kTrial : BootStatus::kConfirmed;
}

fw::update::RevertReason ProgramDownload::reverted() const {
  return supervision_ ? supervision_->reverted : fw::update::RevertReason::kNone;
}

std::uint32_t ProgramDownload::key_fingerprint() const {
  if (!supervision_ || !supervision_->public_key) return 0;
  const auto& k = *supervision_->public_key;
  return std::uint32_t{k[0]} << 24 | std::uint32_t{k[1]} << 16 | std::uint32_t{k[2]} << 8 | k[3];
}

}  // namespace fw_linux
