// The firmware image (docs/flashing.md): a 256-byte header, then the
// program. Little-endian; every field at a fixed offset:
//
//   0   8  magic "DELTAIMG"           64   4  payload length (bytes)
//   8   2  header version (1)         68   4  payload CRC-32
//   10  2  header size (256)          72  32  payload SHA-256
//   12  4  vendor ID   (0x1018:1)     104 24  reserved, zero
//   16  4  product code (0x1018:2)    128 64  Ed25519 signature of bytes 0-127
//   20  4  revision    (0x1018:3)     192 60  reserved, zero
//   24  6  version major, minor, patch (3 x u16)
//   30  2  flags (bit 0: signed,      252  4  CRC-32 of bytes 0-251
//           bit 1: a public key)
//   32 32  build id (ASCII, NUL-padded)
//
// The signature covers the header's first 128 bytes, the payload's SHA-256
// and the signed flag among them, so a signature vouches for the program.
// No heap, no floating point: the controller checks an image as it arrives.
#pragma once

#include <array>
#include <cstdint>
#include <span>

#include "delta/update/crc32.hpp"
#include "delta/update/sha256.hpp"

namespace delta::update {

inline constexpr std::uint32_t kHeaderBytes = 256;
inline constexpr std::uint32_t kSignedBytes = 128;
inline constexpr std::uint16_t kHeaderVersion = 1;
inline constexpr std::array<std::uint8_t, 8> kMagic = {'D', 'E', 'L', 'T', 'A', 'I', 'M', 'G'};
inline constexpr std::uint16_t kFlagSigned = 0x0001;
// A key image: its payload is the next public key (32 bytes), signed with
// the installed one (docs/security.md).
inline constexpr std::uint16_t kFlagPublicKey = 0x0002;

using HeaderBytes = std::array<std::uint8_t, kHeaderBytes>;
using Signature = std::array<std::uint8_t, 64>;

// What 0x1018 says of a node: the image must be for the same vendor and
// product. The revision is the program's own (what 0x1018:3 reads once it runs).
struct Identity {
  std::uint32_t vendor_id{0};
  std::uint32_t product_code{0};
  std::uint32_t revision{0};
};

struct Version {
  std::uint16_t major{0};
  std::uint16_t minor{0};
  std::uint16_t patch{0};
};
// -1, 0, 1 as a is older than, the same as, newer than b.
int compare(const Version& a, const Version& b);

struct ImageHeader {
  Identity identity;
  Version version;
  std::array<char, 32> build_id{};  // NUL-padded, not necessarily terminated
  std::uint16_t flags{0};
  std::uint32_t payload_bytes{0};
  std::uint32_t payload_crc32{0};
  Sha256Digest payload_sha256{};
  Signature signature{};
  bool is_signed() const { return (flags & kFlagSigned) != 0; }
  bool is_public_key() const { return (flags & kFlagPublicKey) != 0; }
};

// Why an image is refused; each maps to a CiA 302-3 flash status (0x1F57).
enum class Verdict : std::uint8_t {
  kOk,
  kNotAnImage,            // wrong magic
  kUnknownHeaderVersion,  // a header version this code does not read
  kHeaderCrc,             // the header's CRC-32 does not match
  kReservedNotZero,       // reserved bytes set: a format this code does not know
  kTooLarge,              // the payload does not fit the slot
  kLengthMismatch,        // more or fewer bytes than the header says
  kPayloadCrc,            // the payload's CRC-32 does not match the header's
  kPayloadSha256,         // the payload's SHA-256 does not match the header's
  kWrongHardware,         // another vendor or product than this node
  kUnsigned,              // the node requires a signature and the image has none
  kBadSignature,          // the signature does not verify with the node's key
  kWriteError,            // the slot could not be written
  kNoValidProgram,        // start asked with nothing staged
  kInterrupted,           // the download ended before its last byte
  kNoKeyToVouch,          // a key image on a node with no key installed to vouch for it
};
inline constexpr unsigned kVerdictCount = 16;

// CiA 302-3's error code for 0x1F57 bits 1-7 (0 no error, 1 no valid
// program, 2 data format unknown, 3 data format error or CRC error,
// 5 flash write error, 6 general address error, 7 flash secured).
std::uint8_t cia302_error_code(Verdict v);
// A short English description ("payload CRC-32 does not match").
const char* describe(Verdict v);

// Writes a header (its CRC-32 computed here).
void encode_header(const ImageHeader& h, HeaderBytes& out);
// Reads a header; kOk or why not (magic, version, reserved bytes, CRC).
Verdict decode_header(const HeaderBytes& in, ImageHeader& out);
// vendor and product must match the node's 0x1018.
Verdict check_identity(const ImageHeader& h, const Identity& node);

// Checks an image as its bytes arrive, in any pieces: the header once its
// 256 bytes are in, then the payload's length, CRC-32 and SHA-256 at the end.
class ImageCheck {
 public:
  explicit ImageCheck(std::uint32_t capacity_bytes) : capacity_bytes_(capacity_bytes) {}
  // false once the image is refused (verdict() says why); later bytes are ignored.
  bool add(std::span<const std::uint8_t> bytes);
  // After the last byte.
  Verdict finish();
  Verdict verdict() const { return verdict_; }
  // The header arrived and decoded (the payload may still fail its checks).
  bool header_valid() const { return header_valid_; }
  const ImageHeader& header() const { return header_; }
  const HeaderBytes& header_bytes() const { return raw_; }
  std::uint32_t received_bytes() const { return received_; }

 private:
  std::uint32_t capacity_bytes_;
  std::uint32_t received_{0};
  bool header_decoded_{false};
  bool header_valid_{false};
  Verdict verdict_{Verdict::kOk};
  HeaderBytes raw_{};
  ImageHeader header_{};
  Crc32 crc_;
  Sha256 sha_;
};

}  // namespace delta::update
