// Program download on the controller's node (CiA 302-3, docs/flashing.md):
// images streamed by SDO block download into the staging file delta_boot
// names, checked as they arrive, refused with the flash status that says
// why, and the messages delta_boot receives on its pipe.
#include "fw_linux/program_download.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "delta/update/image_file.hpp"
#include "node_rig.hpp"
#include "scratch_directory.hpp"

namespace fw_linux {
namespace {

namespace fs = std::filesystem;
namespace up = delta::update;
namespace p = delta::can::protocol;
namespace sdo = delta::can::sdo;
using delta::can::Frame;
using testing::NodeRig;

std::uint8_t status_code(std::uint32_t flash_status) {
  return static_cast<std::uint8_t>((flash_status >> 1) & 0x7F);
}

// A state folder and the pipe delta_boot would read.
struct Supervisor {
  Supervisor() { EXPECT_EQ(pipe2(fds, O_NONBLOCK | O_CLOEXEC), 0); }
  ~Supervisor() {
    close(fds[0]);
    close(fds[1]);
  }
  boot::Supervision supervision(bool trial = false) const {
    boot::Supervision s;
    s.fd = fds[1];
    s.staging_path = dir + "/incoming.img";
    s.running_crc32 = 0x11223344;
    s.trial = trial;
    s.capacity_bytes = 1 << 20;
    return s;
  }
  std::string messages() const {  // what came since the last call
    std::string all;
    char buffer[256];
    ssize_t n = 0;
    while ((n = read(fds[0], buffer, sizeof buffer)) > 0) all.append(buffer, std::size_t(n));
    return all;
  }
  std::vector<std::uint8_t> staged() const {
    std::ifstream in(dir + "/incoming.img", std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  const testsupport::ScratchDirectory scratch{"program_download_test"};
  const std::string dir = scratch.path();
  int fds[2]{-1, -1};
};

std::vector<std::uint8_t> program_bytes(std::size_t n) {
  std::vector<std::uint8_t> p(n);
  for (std::size_t i = 0; i < n; ++i) p[i] = static_cast<std::uint8_t>(i * 7 + (i >> 8));
  return p;
}

std::vector<std::uint8_t> image_for(const NodeRig& rig, std::uint32_t product) {
  up::ImageFields f;
  f.identity = controller_identity(rig.version);
  f.identity.product_code = product;
  f.version = {rig.version.major, static_cast<std::uint16_t>(rig.version.minor + 1), 0};
  f.build_id = "test";
  return up::make_image(f, program_bytes(20000));
}

// A block download of 0x1F50:1; the abort code (0: done).
sdo::AbortCode download(NodeRig& rig, const std::vector<std::uint8_t>& image) {
  rig.client.download(0x1F50, 1, image, sdo::Transfer::kBlock, rig.now_us);
  rig.transfer();
  return rig.client.abort_code();
}

sdo::AbortCode control(NodeRig& rig, std::uint8_t value) {
  const std::uint8_t v[] = {value};
  rig.client.download(0x1F51, 1, v, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  return rig.client.abort_code();
}

TEST(ProgramDownloadTest, WithoutDelta_bootEveryProgramWriteIsRefused) {
  NodeRig rig;
  rig.step();
  EXPECT_EQ(download(rig, image_for(rig, kControllerProductCode)), sdo::kAbortCannotStore);
  EXPECT_EQ(control(rig, 1), sdo::kAbortCannotStore);
  EXPECT_EQ(rig.read(0x2F00, 1), 0u) << "unsupervised";
  EXPECT_EQ(rig.read(0x1F51, 1), 1u) << "this program runs";
}

TEST(ProgramDownloadTest, AValidImageIsStagedAndStartedThroughDelta_boot) {
  Supervisor boot_side;
  NodeRig rig(boot_side.supervision());
  rig.step();
  EXPECT_EQ(rig.read(0x1F56, 1), 0x11223344u) << "the running program's CRC";
  EXPECT_EQ(rig.read(0x2F00, 1), 2u) << "supervised, confirmed";
  EXPECT_EQ(control(rig, 1), sdo::kAbortDeviceState) << "nothing staged";
  EXPECT_EQ(status_code(rig.read(0x1F57, 1)), 1) << "no valid program";
  const auto image = image_for(rig, kControllerProductCode);
  ASSERT_EQ(download(rig, image), sdo::kNoAbort) << sdo::abort_meaning(rig.client.abort_code());
  EXPECT_EQ(boot_side.staged(), image);
  EXPECT_FALSE(fs::exists(boot_side.dir + "/incoming.img.part"));
  EXPECT_EQ(boot_side.messages(), "staged\n");
  EXPECT_EQ(rig.read(0x1F57, 1), 0u);
  EXPECT_EQ(rig.read(0x1F56, 1), up::check_image(image).header->payload_crc32);
  // Staged: another download waits for a clear (CiA 302-3 "not cleared").
  EXPECT_EQ(download(rig, image), sdo::kAbortDeviceState);
  EXPECT_EQ(status_code(rig.read(0x1F57, 1)), 4);
  EXPECT_EQ(control(rig, 4), sdo::kAbortValueRange);
  EXPECT_EQ(control(rig, 1), sdo::kNoAbort);
  EXPECT_EQ(boot_side.messages(), "start\n");
  EXPECT_EQ(control(rig, 3), sdo::kNoAbort);
  EXPECT_EQ(control(rig, 2), sdo::kNoAbort);
  EXPECT_EQ(boot_side.messages(), "clear\nreset\n");
  EXPECT_EQ(rig.read(0x1F56, 1), 0x11223344u) << "cleared: the running program's again";
  EXPECT_EQ(download(rig, image), sdo::kNoAbort);
}

TEST(ProgramDownloadTest, DefectiveImagesAreRefusedWithTheirFlashStatus) {
  Supervisor boot_side;
  NodeRig rig(boot_side.supervision());
  rig.step();
  auto corrupted = image_for(rig, kControllerProductCode);
  corrupted[corrupted.size() / 2] ^= 0x01;
  EXPECT_EQ(download(rig, corrupted), sdo::kAbortCannotStore);
  std::uint32_t status = rig.read(0x1F57, 1);
  EXPECT_EQ(status_code(status), 3) << "data format error or CRC error";
  EXPECT_EQ(status >> 8, static_cast<unsigned>(up::Verdict::kPayloadCrc));
  const auto other = image_for(rig, kControllerProductCode + 1);
  rig.requests = 0;
  EXPECT_EQ(download(rig, other), sdo::kAbortCannotStore);
  status = rig.read(0x1F57, 1);
  EXPECT_EQ(status >> 8, static_cast<unsigned>(up::Verdict::kWrongHardware));
  EXPECT_EQ(status_code(status), up::cia302_error_code(up::Verdict::kWrongHardware));
  EXPECT_LT(rig.requests, 100u) << "refused once the header was in, not at the end";
  // Nothing was staged, nothing told, no temporary left.
  EXPECT_EQ(boot_side.messages(), "");
  EXPECT_FALSE(fs::exists(boot_side.dir + "/incoming.img"));
  EXPECT_FALSE(fs::exists(boot_side.dir + "/incoming.img.part"));
  // Too large for the slot: refused before a byte is written.
  std::vector<std::uint8_t> huge(boot_side.supervision().capacity_bytes + 1, 0);
  EXPECT_EQ(download(rig, huge), sdo::kAbortLengthTooHigh);
}

TEST(ProgramDownloadTest, AControllerWithAKeyTakesOnlyImagesSignedWithIt) {
  Supervisor boot_side;
  const up::KeyPair ours = up::generate_key_pair();
  const up::KeyPair theirs = up::generate_key_pair();
  auto supervision = boot_side.supervision();
  supervision.public_key = ours.public_key;
  NodeRig rig(supervision);
  rig.step();
  const auto image = image_for(rig, kControllerProductCode);
  EXPECT_EQ(download(rig, image), sdo::kAbortCannotStore);
  EXPECT_EQ(rig.read(0x1F57, 1) >> 8, static_cast<unsigned>(up::Verdict::kUnsigned));
  EXPECT_EQ(status_code(rig.read(0x1F57, 1)), 7) << "secured";
  EXPECT_EQ(download(rig, up::sign_image(image, theirs.seed)), sdo::kAbortCannotStore);
  EXPECT_EQ(rig.read(0x1F57, 1) >> 8, static_cast<unsigned>(up::Verdict::kBadSignature));
  EXPECT_EQ(download(rig, up::sign_image(image, ours.seed)), sdo::kNoAbort);
  EXPECT_EQ(boot_side.messages(), "staged\n");
}

// A key image replaces an installed key: on a controller with none it is
// refused as soon as its header is in (flash secured, check 15), and
// 0x2F00:3 shows the installed key's first four bytes (0: none).
TEST(ProgramDownloadTest, AKeyImageWithoutAnInstalledKeyIsRefused) {
  Supervisor boot_side;
  NodeRig rig(boot_side.supervision());
  rig.step();
  EXPECT_EQ(rig.read(0x2F00, 3), 0u);
  const up::KeyPair next = up::generate_key_pair();
  up::ImageFields f;
  f.identity = controller_identity(rig.version);
  f.version = {1, 0, 0};
  const auto key_image = up::make_key_image(f, next.public_key);
  EXPECT_EQ(download(rig, key_image), sdo::kAbortCannotStore);
  EXPECT_EQ(rig.read(0x1F57, 1) >> 8, static_cast<unsigned>(up::Verdict::kNoKeyToVouch));
  EXPECT_EQ(status_code(rig.read(0x1F57, 1)), 7) << "secured";
  EXPECT_EQ(boot_side.messages(), "");
  const up::KeyPair ours = up::generate_key_pair();
  auto supervision = boot_side.supervision();
  supervision.public_key = ours.public_key;
  NodeRig keyed(supervision);
  keyed.step();
  const auto& k = ours.public_key;
  EXPECT_EQ(keyed.read(0x2F00, 3), std::uint32_t{k[0]} << 24 | std::uint32_t{k[1]} << 16 |
                                       std::uint32_t{k[2]} << 8 | k[3]);
}

TEST(ProgramDownloadTest, NothingIsAcceptedWhileTheControllerIsNotSafeToUpdate) {
  Supervisor boot_side;
  NodeRig rig(boot_side.supervision());
  rig.report.safe_to_update = false;  // a trajectory runs
  rig.step();
  EXPECT_EQ(download(rig, image_for(rig, kControllerProductCode)), sdo::kAbortDeviceState);
  EXPECT_EQ(status_code(rig.read(0x1F57, 1)), 7);
  EXPECT_EQ(control(rig, 0), sdo::kAbortDeviceState);
  EXPECT_EQ(control(rig, 2), sdo::kAbortDeviceState);
  EXPECT_EQ(boot_side.messages(), "");
}

TEST(ProgramDownloadTest, ADownloadCutShortLeavesNothingBehind) {
  Supervisor boot_side;
  NodeRig rig(boot_side.supervision());
  rig.step();
  const auto image = image_for(rig, kControllerProductCode);
  rig.client.download(0x1F50, 1, image, sdo::Transfer::kBlock, rig.now_us);
  // Two requests' worth of frames, then the client goes silent.
  for (int i = 0; i < 300; ++i) {
    sdo::Payload request;
    if (!rig.client.pending(request)) break;
    rig.client.sent(rig.now_us);
    rig.frame(p::cob_id(p::kSdoRx, p::kControllerNode), 8, request);
    for (const Frame& f : rig.bus.take()) {
      if (f.id == p::cob_id(p::kSdoTx, p::kControllerNode)) rig.client.on_frame(f.data, rig.now_us);
    }
  }
  EXPECT_TRUE(fs::exists(boot_side.dir + "/incoming.img.part"));
  rig.client = sdo::Client{};
  rig.step(fw::Fault::kNone, 300);  // 600 ms: the server's timeout
  EXPECT_FALSE(fs::exists(boot_side.dir + "/incoming.img.part"));
  EXPECT_EQ(rig.read(0x1F57, 1) >> 8, static_cast<unsigned>(up::Verdict::kInterrupted));
  EXPECT_EQ(download(rig, image), sdo::kNoAbort) << "a second attempt succeeds";
}

TEST(ProgramDownloadTest, AProgramOnTrialConfirmsOnceReadyAndRefusesUpdatesUntilThen) {
  Supervisor boot_side;
  NodeRig rig(boot_side.supervision(true));
  rig.report.ready = false;
  rig.step();
  EXPECT_EQ(rig.read(0x2F00, 1), 1u) << "on trial";
  EXPECT_EQ(download(rig, image_for(rig, kControllerProductCode)), sdo::kAbortDeviceState);
  EXPECT_EQ(boot_side.messages(), "");
  rig.report.ready = true;
  rig.step(fw::Fault::kNone, 3);
  EXPECT_EQ(boot_side.messages(), "confirm\n") << "once";
  EXPECT_EQ(rig.read(0x2F00, 1), 2u);
}

TEST(ProgramDownloadTest, AfterARollBackTheFirstEmergencySaysWhy) {
  Supervisor boot_side;
  auto supervision = boot_side.supervision();
  supervision.reverted = fw::update::RevertReason::kNoConfirmation;
  NodeRig rig(supervision);
  rig.step(fw::Fault::kNone, 2);
  std::vector<std::pair<std::uint16_t, std::uint16_t>> emcy;  // code, reason
  for (const Frame& f : rig.bus.take()) {
    if (f.id != p::kControllerEmcy.base_id) continue;
    emcy.emplace_back(static_cast<std::uint16_t>(f.data[0] | f.data[1] << 8),
                      std::uint16_t{f.data[3]});
    EXPECT_EQ(f.data[2], 1) << "error register: generic";
  }
  EXPECT_EQ(emcy, (std::vector<std::pair<std::uint16_t, std::uint16_t>>{{0x6200, 1}}));
  EXPECT_EQ(rig.read(0x2F00, 2), 1u);
}

}  // namespace
}  // namespace fw_linux
