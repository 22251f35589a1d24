// Firmware images as files (delta/update/image_file.hpp): make, check,
// sign and verify (Ed25519, libsodium), key files and versions.
#include "delta/update/image_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "delta/input_error.hpp"
#include "scratch_directory.hpp"

namespace delta::update {
namespace {

std::vector<std::uint8_t> program(std::size_t n) {
  std::vector<std::uint8_t> p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>(i ^ (i >> 8));
  return p;
}

const ImageFields kFields{{0xDE17, 0x16, 0x00000001}, {0, 1, 0}, "g0123abc"};

TEST(ImageFileTest, MadeImagesCheckAndCarryTheirFields) {
  const CheckedImage c = check_image(make_image(kFields, program(3000)));
  ASSERT_EQ(c.verdict, Verdict::kOk);
  ASSERT_TRUE(c.header);
  EXPECT_EQ(c.header->payload_bytes, 3000u);
  EXPECT_EQ(build_id_text(*c.header), "g0123abc");
  EXPECT_EQ(version_text(c.header->version), "0.1.0");
  EXPECT_EQ(c.bytes.size(), 3256u);
}

TEST(ImageFileTest, SignedImagesVerifyOnlyWithTheirKeyAndUntouched) {
  const KeyPair k = generate_key_pair();
  const KeyPair other = generate_key_pair();
  const std::vector<std::uint8_t> image = make_image(kFields, program(500));
  const std::vector<std::uint8_t> s = sign_image(image, k.seed);
  const CheckedImage c = check_image(s);
  ASSERT_EQ(c.verdict, Verdict::kOk);
  ASSERT_TRUE(c.header->is_signed());
  const auto header = std::span(c.bytes).first(kHeaderBytes);
  EXPECT_EQ(check_signature(header, *c.header, k.public_key), Verdict::kOk);
  EXPECT_EQ(check_signature(header, *c.header, other.public_key), Verdict::kBadSignature);
  EXPECT_EQ(check_signature(header, *c.header, std::nullopt), Verdict::kOk);
  // Unsigned, with a key required.
  const CheckedImage u = check_image(image);
  EXPECT_EQ(check_signature(std::span(u.bytes).first(kHeaderBytes), *u.header, k.public_key),
            Verdict::kUnsigned);
  // A signed header changed (a newer version claimed), its CRC made right again.
  ImageHeader forged = *c.header;
  forged.version.minor = 9;
  HeaderBytes raw;
  encode_header(forged, raw);
  EXPECT_EQ(check_signature(raw, forged, k.public_key), Verdict::kBadSignature);
  // The program changed with the header kept: the SHA-256 catches it.
  std::vector<std::uint8_t> tampered = s;
  tampered[kHeaderBytes + 10] ^= 1;
  EXPECT_NE(check_image(tampered).verdict, Verdict::kOk);
  EXPECT_EQ(public_key_of(k.seed), k.public_key);
  EXPECT_THROW(sign_image(tampered, k.seed), InputError);
}

TEST(ImageFileTest, BuildIdsAndVersionsAreChecked) {
  ImageFields f = kFields;
  f.build_id = std::string(33, 'a');
  EXPECT_THROW(make_image(f, program(1)), InputError);
  f.build_id = "has space";
  EXPECT_THROW(make_image(f, program(1)), InputError);
  EXPECT_EQ(version_text(parse_version("65535.0.12")), "65535.0.12");
  for (const char* bad : {"", "1", "1.2", "1.2.3.4", "1.2.x", "65536.0.0", "-1.0.0", "1..2"}) {
    EXPECT_THROW(parse_version(bad), InputError) << bad;
  }
}

TEST(ImageFileTest, KeyFilesNameWhatIsWrong) {
  const std::string path = testsupport::process_scratch("image_file_test").file("key");
  const KeyPair k = generate_key_pair();
  std::ofstream(path) << key_text(k.public_key);
  EXPECT_EQ(read_public_key(path), k.public_key);
  std::ofstream(path) << key_text(k.public_key).substr(0, 40) << "zz\n";
  try {
    (void)read_public_key(path);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              path + ":1:41: public key: expected 64 hexadecimal digits (32 bytes)");
  }
  std::ofstream(path) << key_text(k.public_key).substr(0, 64) << "00\n";
  EXPECT_THROW(read_secret_seed(path), InputError);
  ::unlink(path.c_str());
  EXPECT_THROW(read_public_key(path), InputError);
}

}  // namespace
}  // namespace delta::update
