#include "delta/update/image.hpp"

#include "delta/little_endian.hpp"

namespace delta::update {
namespace {

constexpr std::uint32_t kOffsetHeaderVersion = 8;
constexpr std::uint32_t kOffsetHeaderSize = 10;
constexpr std::uint32_t kOffsetIdentity = 12;
constexpr std::uint32_t kOffsetVersion = 24;
constexpr std::uint32_t kOffsetFlags = 30;
constexpr std::uint32_t kOffsetBuildId = 32;
constexpr std::uint32_t kOffsetPayloadBytes = 64;
constexpr std::uint32_t kOffsetPayloadCrc = 68;
constexpr std::uint32_t kOffsetPayloadSha = 72;
constexpr std::uint32_t kOffsetReservedA = 104;
constexpr std::uint32_t kOffsetSignature = 128;
constexpr std::uint32_t kOffsetReservedB = 192;
constexpr std::uint32_t kOffsetHeaderCrc = 252;

bool all_zero(const HeaderBytes& b, std::uint32_t from, std::uint32_t to) {
  for (std::uint32_t i = from; i < to; ++i) {
    if (b[i] != 0) return false;
  }
  return true;
}

}  // namespace

int compare(const Version& a, const Version& b) {
  if (a.major != b.major) return a.major < b.major ? -1 : 1;
  if (a.minor != b.minor) return a.minor < b.minor ? -1 : 1;
  if (a.patch != b.patch) return a.patch < b.patch ? -1 : 1;
  return 0;
}

std::uint8_t cia302_error_code(Verdict v) {
  switch (v) {
    case Verdict::kOk:
      return 0;
    case Verdict::kNoValidProgram:
    case Verdict::kInterrupted:
      return 1;
    case Verdict::kNotAnImage:
    case Verdict::kUnknownHeaderVersion:
    case Verdict::kReservedNotZero:
    case Verdict::kWrongHardware:
      return 2;
    case Verdict::kHeaderCrc:
    case Verdict::kLengthMismatch:
    case Verdict::kPayloadCrc:
    case Verdict::kPayloadSha256:
      return 3;
    case Verdict::kWriteError:
      return 5;
    case Verdict::kTooLarge:
      return 6;
    case Verdict::kUnsigned:
    case Verdict::kBadSignature:
    case Verdict::kNoKeyToVouch:
      return 7;
  }
  return 63;  // unspecified
}

const char* describe(Verdict v) {
  switch (v) {
    case Verdict::kOk:
      return "image valid";
    case Verdict::kNotAnImage:
      return "not a delta firmware image (wrong magic)";
    case Verdict::kUnknownHeaderVersion:
      return "unknown image header version";
    case Verdict::kHeaderCrc:
      return "image header CRC-32 does not match";
    case Verdict::kReservedNotZero:
      return "image header has reserved bytes set";
    case Verdict::kTooLarge:
      return "program larger than the slot";
    case Verdict::kLengthMismatch:
      return "image length differs from its header's";
    case Verdict::kPayloadCrc:
      return "program CRC-32 does not match the header's";
    case Verdict::kPayloadSha256:
      return "program SHA-256 does not match the header's";
    case Verdict::kWrongHardware:
      return "image is for another vendor or product";
    case Verdict::kUnsigned:
      return "image is not signed and this controller requires a signature";
    case Verdict::kBadSignature:
      return "image signature does not verify";
    case Verdict::kWriteError:
      return "slot write error";
    case Verdict::kNoValidProgram:
      return "no valid program staged";
    case Verdict::kInterrupted:
      return "download interrupted before its last byte";
    case Verdict::kNoKeyToVouch:
      return "a key image, and this controller has no public key installed to vouch for it "
             "(the first key is installed on the controller: delta_boot --public-key)";
  }
  return "unknown verdict";
}

void encode_header(const ImageHeader& h, HeaderBytes& out) {
  out = HeaderBytes{};
  for (std::uint32_t i = 0; i < kMagic.size(); ++i) out[i] = kMagic[i];
  put_le16(out, kOffsetHeaderVersion, kHeaderVersion);
  put_le16(out, kOffsetHeaderSize, static_cast<std::uint16_t>(kHeaderBytes));
  put_le32(out, kOffsetIdentity, h.identity.vendor_id);
  put_le32(out, kOffsetIdentity + 4, h.identity.product_code);
  put_le32(out, kOffsetIdentity + 8, h.identity.revision);
  put_le16(out, kOffsetVersion, h.version.major);
  put_le16(out, kOffsetVersion + 2, h.version.minor);
  put_le16(out, kOffsetVersion + 4, h.version.patch);
  put_le16(out, kOffsetFlags, h.flags);
  for (std::uint32_t i = 0; i < h.build_id.size(); ++i) {
    out[kOffsetBuildId + i] = static_cast<std::uint8_t>(h.build_id[i]);
  }
  put_le32(out, kOffsetPayloadBytes, h.payload_bytes);
  put_le32(out, kOffsetPayloadCrc, h.payload_crc32);
  for (std::uint32_t i = 0; i < 32; ++i) out[kOffsetPayloadSha + i] = h.payload_sha256[i];
  for (std::uint32_t i = 0; i < 64; ++i) out[kOffsetSignature + i] = h.signature[i];
  put_le32(out, kOffsetHeaderCrc, crc32(std::span(out.data(), kOffsetHeaderCrc)));
}

Verdict decode_header(const HeaderBytes& in, ImageHeader& out) {
  for (std::uint32_t i = 0; i < kMagic.size(); ++i) {
    if (in[i] != kMagic[i]) return Verdict::kNotAnImage;
  }
  if (get_le16(in, kOffsetHeaderVersion) != kHeaderVersion ||
      get_le16(in, kOffsetHeaderSize) != kHeaderBytes) {
    return Verdict::kUnknownHeaderVersion;
  }
  if (get_le32(in, kOffsetHeaderCrc) != crc32(std::span(in.data(), kOffsetHeaderCrc))) {
    return Verdict::kHeaderCrc;
  }
  if (!all_zero(in, kOffsetReservedA, kOffsetSignature) ||
      !all_zero(in, kOffsetReservedB, kOffsetHeaderCrc) ||
      (get_le16(in, kOffsetFlags) & ~(kFlagSigned | kFlagPublicKey)) != 0) {
    return Verdict::kReservedNotZero;
  }
  out.identity = {get_le32(in, kOffsetIdentity), get_le32(in, kOffsetIdentity + 4),
                  get_le32(in, kOffsetIdentity + 8)};
  out.version = {get_le16(in, kOffsetVersion), get_le16(in, kOffsetVersion + 2),
                 get_le16(in, kOffsetVersion + 4)};
  out.flags = get_le16(in, kOffsetFlags);
  for (std::uint32_t i = 0; i < out.build_id.size(); ++i) {
    out.build_id[i] = static_cast<char>(in[kOffsetBuildId + i]);
  }
  out.payload_bytes = get_le32(in, kOffsetPayloadBytes);
  out.payload_crc32 = get_le32(in, kOffsetPayloadCrc);
  for (std::uint32_t i = 0; i < 32; ++i) out.payload_sha256[i] = in[kOffsetPayloadSha + i];
  for (std::uint32_t i = 0; i < 64; ++i) out.signature[i] = in[kOffsetSignature + i];
  return Verdict::kOk;
}

Verdict check_identity(const ImageHeader& h, const Identity& node) {
  const bool same =
      h.identity.vendor_id == node.vendor_id && h.identity.product_code == node.product_code;
  return same ? Verdict::kOk : Verdict::kWrongHardware;
}

bool ImageCheck::add(std::span<const std::uint8_t> bytes) {
  if (verdict_ != Verdict::kOk) return false;
  std::size_t used = 0;
  while (received_ < kHeaderBytes && used < bytes.size()) raw_[received_++] = bytes[used++];
  if (received_ == kHeaderBytes && !header_decoded_) {
    header_decoded_ = true;
    verdict_ = decode_header(raw_, header_);
    header_valid_ = verdict_ == Verdict::kOk;
    if (header_valid_ && header_.payload_bytes > capacity_bytes_) {
      verdict_ = Verdict::kTooLarge;
    }
    if (verdict_ != Verdict::kOk) return false;
  }
  const std::span<const std::uint8_t> payload = bytes.subspan(used);
  if (payload.empty()) return true;
  if (std::uint64_t{received_} + payload.size() >
      std::uint64_t{kHeaderBytes} + header_.payload_bytes) {
    verdict_ = Verdict::kLengthMismatch;
    return false;
  }
  crc_.add(payload);
  sha_.add(payload);
  received_ += static_cast<std::uint32_t>(payload.size());
  return true;
}

Verdict ImageCheck::finish() {
  if (verdict_ != Verdict::kOk) return verdict_;
  if (!header_decoded_) {
    // Too short for a header: not an image unless it begins like one.
    bool magic = received_ > 0;
    for (std::uint32_t i = 0; i < received_ && i < kMagic.size(); ++i)
      magic &= raw_[i] == kMagic[i];
    verdict_ = magic ? Verdict::kLengthMismatch : Verdict::kNotAnImage;
    return verdict_;
  }
  if (received_ != kHeaderBytes + header_.payload_bytes) {
    verdict_ = Verdict::kLengthMismatch;
    return verdict_;
  }
  if (crc_.value() != header_.payload_crc32) {
    verdict_ = Verdict::kPayloadCrc;
  } else if (sha_.finish() != header_.payload_sha256) {
    verdict_ = Verdict::kPayloadSha256;
  }
  return verdict_;
}

}  // namespace delta::update
