// The firmware image's checks (delta/update): CRC-32 and SHA-256 against the
// published check values (the CRC catalogue's "123456789"; FIPS 180-4's
// examples), streaming in any pieces, the header's round trip and each
// refusal of ImageCheck.
#include "delta/update/image.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <random>
#include <string>
#include <string_view>
#include <vector>

namespace delta::update {
namespace {

std::span<const std::uint8_t> bytes_of(std::string_view s) {
  return {reinterpret_cast<const std::uint8_t*>(s.data()), s.size()};
}

std::string hex(const Sha256Digest& d) {
  std::string s;
  char b[3];
  for (const std::uint8_t x : d) {
    std::snprintf(b, sizeof b, "%02x", x);
    s += b;
  }
  return s;
}

TEST(Crc32Test, CheckValues) {
  EXPECT_EQ(crc32(bytes_of("123456789")), 0xCBF43926u);
  EXPECT_EQ(crc32(bytes_of("")), 0x00000000u);
  EXPECT_EQ(crc32(bytes_of("The quick brown fox jumps over the lazy dog")), 0x414FA339u);
}

TEST(Sha256Test, Fips180Examples) {
  EXPECT_EQ(hex(sha256(bytes_of(""))),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(hex(sha256(bytes_of("abc"))),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(hex(sha256(bytes_of("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"))),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  Sha256 million;
  const std::string thousand(1000, 'a');
  for (int i = 0; i < 1000; ++i) million.add(bytes_of(thousand));
  EXPECT_EQ(hex(million.finish()),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

// Every length around the padding boundaries (55, 56, 63, 64 bytes), and
// random splits, give what one call gives.
TEST(Sha256Test, StreamingInPiecesMatchesOneCall) {
  std::mt19937 rng(7);
  for (std::size_t n : {0u, 1u, 55u, 56u, 57u, 63u, 64u, 65u, 119u, 120u, 128u, 1000u}) {
    std::vector<std::uint8_t> data(n);
    for (auto& b : data) b = static_cast<std::uint8_t>(rng());
    Sha256 s;
    Crc32 c;
    std::size_t at = 0;
    while (at < n) {
      const std::size_t piece = std::min<std::size_t>(n - at, 1 + rng() % 70);
      s.add(std::span(data).subspan(at, piece));
      c.add(std::span(data).subspan(at, piece));
      at += piece;
    }
    EXPECT_EQ(s.finish(), sha256(data)) << n;
    EXPECT_EQ(c.value(), crc32(data)) << n;
  }
}

struct Image {
  ImageHeader header;
  std::vector<std::uint8_t> bytes;
};

Image make_image(std::size_t payload_bytes) {
  Image im;
  std::vector<std::uint8_t> payload(payload_bytes);
  for (std::size_t i = 0; i < payload_bytes; ++i)
    payload[i] = static_cast<std::uint8_t>(i * 31 + 7);
  im.header.identity = {0xDE17, 0x16, 0x00010002};
  im.header.version = {1, 2, 3};
  const std::string_view id = "g1234567";
  for (std::size_t i = 0; i < id.size(); ++i) im.header.build_id[i] = id[i];
  im.header.payload_bytes = static_cast<std::uint32_t>(payload_bytes);
  im.header.payload_crc32 = crc32(payload);
  im.header.payload_sha256 = sha256(payload);
  HeaderBytes raw;
  encode_header(im.header, raw);
  im.bytes.assign(raw.begin(), raw.end());
  im.bytes.insert(im.bytes.end(), payload.begin(), payload.end());
  return im;
}

Verdict check(const std::vector<std::uint8_t>& bytes, std::uint32_t capacity = 1u << 20,
              std::size_t piece = 97) {
  ImageCheck c(capacity);
  for (std::size_t at = 0; at < bytes.size(); at += piece) {
    if (!c.add(std::span(bytes).subspan(at, std::min(piece, bytes.size() - at)))) break;
  }
  return c.finish();
}

TEST(ImageTest, HeaderRoundTrip) {
  const Image im = make_image(1000);
  HeaderBytes raw;
  std::copy_n(im.bytes.begin(), kHeaderBytes, raw.begin());
  ImageHeader back;
  ASSERT_EQ(decode_header(raw, back), Verdict::kOk);
  EXPECT_EQ(back.identity.vendor_id, 0xDE17u);
  EXPECT_EQ(back.identity.product_code, 0x16u);
  EXPECT_EQ(back.identity.revision, 0x00010002u);
  EXPECT_EQ(compare(back.version, Version{1, 2, 3}), 0);
  EXPECT_EQ(std::string(back.build_id.data()), "g1234567");
  EXPECT_EQ(back.payload_bytes, 1000u);
  EXPECT_EQ(back.payload_crc32, im.header.payload_crc32);
  EXPECT_EQ(back.payload_sha256, im.header.payload_sha256);
  EXPECT_FALSE(back.is_signed());
  // The fixed offsets of docs/flashing.md.
  EXPECT_EQ(std::string(raw.begin(), raw.begin() + 8), "DELTAIMG");
  EXPECT_EQ(raw[64] | (raw[65] << 8), 1000);
  EXPECT_EQ(raw[24], 1);
  EXPECT_EQ(raw[26], 2);
  EXPECT_EQ(raw[28], 3);
}

TEST(ImageTest, AValidImageInAnyPiecesIsAccepted) {
  const Image im = make_image(5000);
  for (std::size_t piece : {1u, 7u, 256u, 889u, 100000u}) {
    EXPECT_EQ(check(im.bytes, 1u << 20, piece), Verdict::kOk) << piece;
  }
  EXPECT_EQ(check(make_image(0).bytes), Verdict::kOk);
}

TEST(ImageTest, EachDefectHasItsVerdict) {
  const Image im = make_image(5000);
  auto with = [&](std::size_t at, std::uint8_t x) {
    std::vector<std::uint8_t> b = im.bytes;
    b[at] ^= x;
    return b;
  };
  EXPECT_EQ(check(with(0, 1)), Verdict::kNotAnImage);
  EXPECT_EQ(check(with(8, 2)), Verdict::kUnknownHeaderVersion);
  EXPECT_EQ(check(with(40, 1)), Verdict::kHeaderCrc);  // the build id, under the header CRC
  EXPECT_EQ(check(with(kHeaderBytes + 4000, 0x10)), Verdict::kPayloadCrc);
  EXPECT_EQ(check(im.bytes, 4999), Verdict::kTooLarge);
  EXPECT_EQ(check(std::vector<std::uint8_t>(im.bytes.begin(), im.bytes.end() - 1)),
            Verdict::kLengthMismatch);
  std::vector<std::uint8_t> longer = im.bytes;
  longer.push_back(0);
  EXPECT_EQ(check(longer), Verdict::kLengthMismatch);
  EXPECT_EQ(check(std::vector<std::uint8_t>(im.bytes.begin(), im.bytes.begin() + 100)),
            Verdict::kLengthMismatch);
  EXPECT_EQ(check(std::vector<std::uint8_t>{'M', 'Z', 0x90}), Verdict::kNotAnImage);
  EXPECT_EQ(check({}), Verdict::kNotAnImage);
}

// The header stays readable when only the program is wrong (host_id image
// info prints it), and is not when the header itself is.
TEST(ImageTest, TheHeaderIsValidWhenOnlyTheProgramIsWrong) {
  std::vector<std::uint8_t> b = make_image(400).bytes;
  b[kHeaderBytes + 7] ^= 4;
  ImageCheck program_wrong(1u << 20);
  (void)program_wrong.add(b);
  EXPECT_EQ(program_wrong.finish(), Verdict::kPayloadCrc);
  EXPECT_TRUE(program_wrong.header_valid());
  EXPECT_EQ(program_wrong.header().payload_bytes, 400u);
  b[50] ^= 1;
  ImageCheck header_wrong(1u << 20);
  EXPECT_FALSE(header_wrong.add(b));
  EXPECT_EQ(header_wrong.finish(), Verdict::kHeaderCrc);
  EXPECT_FALSE(header_wrong.header_valid());
  ImageCheck too_short(1u << 20);
  (void)too_short.add(std::span(b).first(200));
  EXPECT_FALSE(too_short.header_valid());
}

// A header with a right CRC-32 but a wrong SHA-256 (the CRC alone does not
// vouch for the program), and reserved bytes set under a valid header CRC.
TEST(ImageTest, Sha256AndReservedBytesAreCheckedToo) {
  Image im = make_image(300);
  ImageHeader h = im.header;
  h.payload_sha256[5] ^= 1;
  HeaderBytes raw;
  encode_header(h, raw);
  std::vector<std::uint8_t> b(raw.begin(), raw.end());
  b.insert(b.end(), im.bytes.begin() + kHeaderBytes, im.bytes.end());
  EXPECT_EQ(check(b), Verdict::kPayloadSha256);

  h = im.header;
  h.flags = 0x0100;  // an unknown flag
  encode_header(h, raw);
  b.assign(raw.begin(), raw.end());
  b.insert(b.end(), im.bytes.begin() + kHeaderBytes, im.bytes.end());
  EXPECT_EQ(check(b), Verdict::kReservedNotZero);
}

TEST(ImageTest, IdentityAndVersions) {
  const Image im = make_image(10);
  EXPECT_EQ(check_identity(im.header, {0xDE17, 0x16, 0x00010000}), Verdict::kOk);
  EXPECT_EQ(check_identity(im.header, {0xDE17, 0x17, 0x00010002}), Verdict::kWrongHardware);
  EXPECT_EQ(check_identity(im.header, {0xDE18, 0x16, 0x00010002}), Verdict::kWrongHardware);
  EXPECT_LT(compare({0, 9, 9}, {1, 0, 0}), 0);
  EXPECT_GT(compare({1, 2, 4}, {1, 2, 3}), 0);
  EXPECT_LT(compare({1, 1, 9}, {1, 2, 0}), 0);
}

TEST(ImageTest, EveryVerdictHasACia302CodeAndAText) {
  for (unsigned v = 0; v < kVerdictCount; ++v) {
    const auto verdict = static_cast<Verdict>(v);
    EXPECT_LE(cia302_error_code(verdict), 7u);
    EXPECT_EQ(cia302_error_code(verdict) == 0, verdict == Verdict::kOk);
    EXPECT_NE(std::string(describe(verdict)), "unknown verdict");
  }
  EXPECT_EQ(cia302_error_code(Verdict::kPayloadCrc), 3u);
  EXPECT_EQ(cia302_error_code(Verdict::kBadSignature), 7u);
}

}  // namespace
}  // namespace delta::update
