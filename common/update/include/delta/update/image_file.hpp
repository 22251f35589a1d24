// Firmware images as files (docs/flashing.md): make one from a program,
// read and check one, sign one. The header format and the checks are the
// portable ones the controller runs (delta/update/image.hpp).
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "delta/update/image.hpp"
#include "delta/update/signature.hpp"

namespace delta::update {

struct ImageFields {
  Identity identity;
  Version version;
  std::string build_id;    // at most 32 ASCII characters
  bool public_key{false};  // a key image: the program is the next public key
};

// The image's bytes: the header, then the program. InputError for a build
// id over 32 characters or not printable ASCII, or a program over 4 GiB.
std::vector<std::uint8_t> make_image(const ImageFields& fields,
                                     std::span<const std::uint8_t> program);

struct CheckedImage {
  std::vector<std::uint8_t> bytes;
  std::optional<ImageHeader> header;  // when the header is valid
  Verdict verdict{Verdict::kOk};      // format, length, CRC-32, SHA-256
};
CheckedImage check_image(std::vector<std::uint8_t> bytes);
// InputError when the file cannot be read; a bad image is a verdict.
CheckedImage read_image(const std::string& path);

// A key image (kFlagPublicKey): its payload is `key`. Signed with the
// installed key, it replaces it on a controller (docs/security.md).
std::vector<std::uint8_t> make_key_image(ImageFields fields, const PublicKey& key);
// The next public key a valid key image carries: nothing for another
// image or a payload that is not 32 bytes.
std::optional<PublicKey> key_of(const CheckedImage& image);

// The signed image: the signed flag set, the signature of the header's first
// 128 bytes written, the header's CRC-32 recomputed. The image must be valid.
std::vector<std::uint8_t> sign_image(std::span<const std::uint8_t> image, const SecretSeed& seed);
// With no key: kOk. With a key: kUnsigned for an unsigned image,
// kBadSignature when it does not verify.
Verdict check_signature(std::span<const std::uint8_t> header_bytes, const ImageHeader& header,
                        const std::optional<PublicKey>& key);

// "1.2.3"; InputError for anything else (each part 0 to 65535).
Version parse_version(const std::string& text);
std::string version_text(const Version& v);
std::string build_id_text(const ImageHeader& h);

}  // namespace delta::update
