#include "delta/update/image_file.hpp"

#include <algorithm>
#include <charconv>

#include "delta/input_error.hpp"
#include "delta/read_file.hpp"

namespace delta::update {

std::vector<std::uint8_t> make_image(const ImageFields& fields,
                                     std::span<const std::uint8_t> program) {
  ImageHeader h;
  if (fields.build_id.size() > h.build_id.size()) {
    throw InputError("image: build id '" + fields.build_id + "' is longer than 32 characters");
  }
  for (std::size_t i = 0; i < fields.build_id.size(); ++i) {
    const char c = fields.build_id[i];
    if (c < 0x21 || c > 0x7E) {
      throw InputError("image: build id '" + fields.build_id + "': character " +
                       std::to_string(i + 1) + " is not printable ASCII");
    }
    h.build_id[i] = c;
  }
  if (program.size() > 0xFFFFFFFFu - kHeaderBytes) {
    throw InputError("image: the program is larger than 4 GiB");
  }
  h.identity = fields.identity;
  h.version = fields.version;
  if (fields.public_key) h.flags = kFlagPublicKey;
  h.payload_bytes = static_cast<std::uint32_t>(program.size());
  h.payload_crc32 = crc32(program);
  h.payload_sha256 = sha256(program);
  HeaderBytes raw;
  encode_header(h, raw);
  std::vector<std::uint8_t> out(kHeaderBytes + program.size());
  std::copy(raw.begin(), raw.end(), out.begin());
  std::copy(program.begin(), program.end(), out.begin() + kHeaderBytes);
  return out;
}

std::vector<std::uint8_t> make_key_image(ImageFields fields, const PublicKey& key) {
  fields.public_key = true;
  return make_image(fields, key);
}

std::optional<PublicKey> key_of(const CheckedImage& image) {
  if (image.verdict != Verdict::kOk || !image.header || !image.header->is_public_key() ||
      image.header->payload_bytes != 32 || image.bytes.size() != kHeaderBytes + 32) {
    return std::nullopt;
  }
  PublicKey key;
  std::copy(image.bytes.begin() + kHeaderBytes, image.bytes.end(), key.begin());
  return key;
}

CheckedImage check_image(std::vector<std::uint8_t> bytes) {
  CheckedImage c;
  c.bytes = std::move(bytes);
  if (c.bytes.size() > 0xFFFFFFFFu) {
    c.verdict = Verdict::kTooLarge;
    return c;
  }
  ImageCheck check(0xFFFFFFFFu);
  (void)check.add(c.bytes);
  c.verdict = check.finish();
  if (check.header_valid()) c.header = check.header();
  return c;
}

CheckedImage read_image(const std::string& path) {
  const FileBytes file = read_file_bytes(path);
  const std::string_view v = file.view();
  return check_image(std::vector<std::uint8_t>(v.begin(), v.end()));
}

std::vector<std::uint8_t> sign_image(std::span<const std::uint8_t> image, const SecretSeed& seed) {
  CheckedImage c = check_image({image.begin(), image.end()});
  if (c.verdict != Verdict::kOk || !c.header) {
    throw InputError(std::string("image: cannot sign an invalid image: ") + describe(c.verdict));
  }
  ImageHeader h = *c.header;
  h.flags = static_cast<std::uint16_t>(h.flags | kFlagSigned);
  h.signature = Signature{};
  HeaderBytes raw;
  encode_header(h, raw);
  h.signature = sign(std::span(raw.data(), kSignedBytes), seed);
  encode_header(h, raw);
  std::copy(raw.begin(), raw.end(), c.bytes.begin());
  return std::move(c.bytes);
}

Verdict check_signature(std::span<const std::uint8_t> header_bytes, const ImageHeader& header,
                        const std::optional<PublicKey>& key) {
  if (!key) return Verdict::kOk;
  if (!header.is_signed()) return Verdict::kUnsigned;
  if (header_bytes.size() < kSignedBytes) return Verdict::kBadSignature;
  return verify(header_bytes.first(kSignedBytes), header.signature, *key) ? Verdict::kOk
                                                                          : Verdict::kBadSignature;
}

Version parse_version(const std::string& text) {
  Version v;
  std::uint16_t* parts[3] = {&v.major, &v.minor, &v.patch};
  const char* p = text.data();
  const char* end = text.data() + text.size();
  for (int i = 0; i < 3; ++i) {
    unsigned long n = 0;
    const auto r = std::from_chars(p, end, n);
    const bool last = i == 2;
    if (r.ec != std::errc() || n > 0xFFFF ||
        (last ? r.ptr != end : (r.ptr == end || *r.ptr != '.'))) {
      throw InputError("version '" + text + "': expected MAJOR.MINOR.PATCH, each 0 to 65535");
    }
    *parts[i] = static_cast<std::uint16_t>(n);
    p = r.ptr + (last ? 0 : 1);
  }
  return v;
}

std::string version_text(const Version& v) {
  return std::to_string(v.major) + "." + std::to_string(v.minor) + "." + std::to_string(v.patch);
}

std::string build_id_text(const ImageHeader& h) {
  std::string s;
  for (const char c : h.build_id) {
    if (c == '\0') break;
    s += c;
  }
  return s;
}

}  // namespace delta::update
