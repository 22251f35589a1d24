// The flash session's decisions that need no bus: the node's identity and
// version against the image's, and the flash status in words. The transfer
// itself is tested on vcan against delta_boot and delta_fw (hil_flash).
#include "host_id/flash.hpp"

#include <gtest/gtest.h>

#include <string>

#include "delta/update/image_file.hpp"

namespace host_id {
namespace {

namespace up = delta::update;

up::ImageHeader image_of(std::uint32_t vendor, std::uint32_t product, up::Version v) {
  up::ImageHeader h;
  h.identity = {vendor, product, 0};
  h.version = v;
  return h;
}

FlashOptions options() {
  FlashOptions o;
  o.image = "fw.img";
  o.node = 16;
  return o;
}

int refused_code(const up::ImageHeader& h, const NodeIdentity& node, const FlashOptions& o,
                 std::string& message) {
  try {
    (void)check_target(h, node, o);
  } catch (const FlashError& e) {
    message = e.message;
    return e.exit_code;
  }
  return 0;
}

TEST(FlashTest, TheSameProductAtANewerVersionIsSentWithoutAWarning) {
  const TargetCheck c =
      check_target(image_of(0xDE17, 1, {0, 2, 0}), {{0xDE17, 1, 0x00010000}, "0.1.0"}, options());
  EXPECT_FALSE(c.warning);
  EXPECT_EQ(up::version_text(c.running), "0.1.0");
}

TEST(FlashTest, AnotherProductIsRefusedNamingBothUnlessForced) {
  const up::ImageHeader h = image_of(0xDE17, 2, {0, 2, 0});
  const NodeIdentity node{{0xDE17, 1, 0}, "0.1.0"};
  std::string message;
  EXPECT_EQ(refused_code(h, node, options(), message), kExitFlashRefusedHere);
  EXPECT_EQ(message,
            "fw.img is for vendor 0x0000DE17, product 0x00000002; node 16 is vendor 0x0000DE17, "
            "product 0x00000001 (--force sends it anyway)");
  FlashOptions forced = options();
  forced.force = true;
  const TargetCheck c = check_target(h, node, forced);
  ASSERT_TRUE(c.warning);
  EXPECT_NE(c.warning->find("sending it as --force asks"), std::string::npos) << *c.warning;
}

TEST(FlashTest, AnOlderVersionIsRefusedUnlessAllowed) {
  const up::ImageHeader h = image_of(0xDE17, 1, {0, 1, 0});
  const NodeIdentity node{{0xDE17, 1, 0}, "0.2.0"};
  std::string message;
  EXPECT_EQ(refused_code(h, node, options(), message), kExitFlashRefusedHere);
  EXPECT_EQ(message,
            "fw.img holds version 0.1.0, older than the running 0.2.0 (--allow-downgrade to "
            "flash it)");
  FlashOptions allowed = options();
  allowed.allow_downgrade = true;
  EXPECT_FALSE(check_target(h, node, allowed).warning);
  // The same version again is no downgrade.
  EXPECT_EQ(refused_code(image_of(0xDE17, 1, {0, 2, 0}), node, options(), message), 0);
}

// A node whose 0x100A is not a version ("unknown") is at the version its
// revision number says: major in the high half, minor in the low.
TEST(FlashTest, AVersionTextThatDoesNotParseIsTakenFromTheRevision) {
  const NodeIdentity node{{0xDE17, 1, 0x00030002}, "unknown"};
  const TargetCheck c = check_target(image_of(0xDE17, 1, {3, 4, 0}), node, options());
  EXPECT_EQ(up::version_text(c.running), "3.2.0");
  std::string message;
  EXPECT_EQ(refused_code(image_of(0xDE17, 1, {3, 1, 9}), node, options(), message),
            kExitFlashRefusedHere);
}

// 0x1F57: bit 0 busy, bits 1-7 CiA 302-3's error code, bits 8-15 our
// verdict (docs/flashing.md).
TEST(FlashTest, TheFlashStatusIsSaidInWords) {
  EXPECT_EQ(flash_status_text(0), "no error");
  EXPECT_EQ(flash_status_text(3u << 1), "data format error or CRC error");
  const auto crc = static_cast<std::uint32_t>(up::Verdict::kPayloadCrc);
  EXPECT_EQ(flash_status_text(3u << 1 | crc << 8), std::string("data format error or CRC error (") +
                                                       up::describe(up::Verdict::kPayloadCrc) +
                                                       ")");
  EXPECT_EQ(flash_status_text(9u << 1), "error code 9");
  EXPECT_EQ(flash_status_text(7u << 1), "flash secured (write access not allowed now)");
}

}  // namespace
}  // namespace host_id
