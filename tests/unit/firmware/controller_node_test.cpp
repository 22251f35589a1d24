// The controller's own CANopen node (node 16): boot-up and heartbeat, its
// SDO server and object dictionary (against docs/eds/delta_fw.eds), NMT
// commands, and emergencies.
#include "fw_linux/controller_node.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "delta/can/protocol.hpp"
#include "node_rig.hpp"

namespace fw_linux {
namespace {

namespace p = delta::can::protocol;
namespace sdo = delta::can::sdo;
using delta::can::Frame;
using testing::NodeRig;

TEST(ControllerNodeTest, BootsUpThenSendsItsHeartbeatEveryHeartbeatTime) {
  NodeRig rig;  // 2 ms cycles, heartbeat every 50 ms
  rig.step();
  EXPECT_EQ(rig.heartbeats(), std::vector<std::uint8_t>{0});  // boot-up
  rig.step(fw::Fault::kNone, 100);
  EXPECT_EQ(rig.heartbeats(), (std::vector<std::uint8_t>{5, 5, 5, 5}));  // 200 ms, operational
  EXPECT_TRUE(rig.node.pdos_allowed());
}

TEST(ControllerNodeTest, AnswersSdoWithItsIdentityNameAndVersion) {
  NodeRig rig;
  rig.step();
  EXPECT_EQ(rig.read(0x1018, 1), kControllerVendorId);
  EXPECT_EQ(rig.read(0x1018, 2), kControllerProductCode);
  EXPECT_EQ(rig.read(0x1018, 3), (std::uint32_t{rig.version.major} << 16) | rig.version.minor);
  EXPECT_EQ(rig.read_text(0x1008), "delta_fw");  // 8 bytes: a segmented upload
  EXPECT_EQ(rig.read_text(0x100A), DELTA_PROJECT_VERSION);
  EXPECT_EQ(rig.read(0x1800, 1), p::kLogA.base_id);
  EXPECT_EQ(rig.read(0x1802, 1), p::kLogC.base_id);
  const std::uint8_t one[] = {10};
  rig.client.download(0x1017, 0, one, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  EXPECT_EQ(rig.client.abort_code(), sdo::kAbortLengthTooLow);
  const std::uint8_t four[] = {0, 0, 0, 0};
  rig.client.download(0x1000, 0, four, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  EXPECT_EQ(rig.client.abort_code(), sdo::kAbortReadOnly);
  // The producer heartbeat time is writable: 10 ms.
  const std::uint8_t ten[] = {10, 0};
  rig.client.download(0x1017, 0, ten, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  ASSERT_EQ(rig.client.status(), sdo::ClientStatus::kDone);
  rig.bus.take();
  rig.step(fw::Fault::kNone, 50);
  EXPECT_EQ(rig.heartbeats().size(), 10u);
}

TEST(ControllerNodeTest, ObeysNmtForItselfAndAllAndIgnoresOtherNodes) {
  NodeRig rig;
  rig.step();
  rig.nmt(p::kNmtStop, 3);  // another node's
  EXPECT_TRUE(rig.node.pdos_allowed());
  rig.nmt(p::kNmtStop, p::kControllerNode);
  EXPECT_FALSE(rig.node.pdos_allowed());
  rig.bus.take();
  // Stopped: the heartbeat says so; no SDO answer, no EMCY.
  rig.step(fw::Fault::kDriveConfigFailed, 25);
  bool emcy = false;
  for (const Frame& f : rig.bus.frames) emcy = emcy || f.id == p::kControllerEmcy.base_id;
  EXPECT_FALSE(emcy);
  EXPECT_EQ(rig.heartbeats(), std::vector<std::uint8_t>{4});
  rig.frame(p::cob_id(p::kSdoRx, p::kControllerNode), 8, sdo::upload_request(0x1000, 0));
  EXPECT_TRUE(rig.bus.take().empty());
  rig.nmt(p::kNmtEnterPreOperational, 0);  // all nodes
  rig.step(fw::Fault::kDriveConfigFailed, 25);
  EXPECT_FALSE(rig.node.pdos_allowed());
  EXPECT_EQ(rig.heartbeats(), std::vector<std::uint8_t>{127});
  rig.nmt(p::kNmtStart, 0);
  EXPECT_TRUE(rig.node.pdos_allowed());
  EXPECT_EQ(rig.read(0x1001, 0), 1u);  // in fault: the error register's generic bit
}

TEST(ControllerNodeTest, ResetCommunicationRestoresTheHeartbeatAndBootsUpAgain) {
  NodeRig rig;
  rig.step();
  const std::uint8_t zero[] = {0, 0};
  rig.client.download(0x1017, 0, zero, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  rig.bus.take();
  rig.step(fw::Fault::kNone, 50);
  EXPECT_TRUE(rig.heartbeats().empty());  // 0: no heartbeat
  rig.nmt(p::kNmtResetCommunication, p::kControllerNode);
  rig.step(fw::Fault::kNone, 25);
  EXPECT_EQ(rig.heartbeats(), (std::vector<std::uint8_t>{0, 5}));
  EXPECT_EQ(rig.read(0x1017, 0), 50u);
}

TEST(ControllerNodeTest, SendsAnEmergencyOnEnteringAndLeavingAFault) {
  NodeRig rig;
  rig.step();
  rig.bus.take();
  rig.step(fw::Fault::kDriveConfigFailed);
  rig.step(fw::Fault::kDriveConfigFailed);
  rig.step(fw::Fault::kNone);
  std::vector<std::uint16_t> codes;
  for (const Frame& f : rig.bus.take()) {
    if (f.id == p::kControllerEmcy.base_id)
      codes.push_back(static_cast<std::uint16_t>(f.data[0] | f.data[1] << 8));
  }
  EXPECT_EQ(codes, (std::vector<std::uint16_t>{0xFF0A, 0x0000}));
}

TEST(ControllerNodeTest, ItsEdsListsExactlyItsObjects) {
  NodeRig rig;
  const delta::canopen::Eds eds = delta::canopen::read_eds(DELTA_EDS_DIR "/delta_fw.eds");
  EXPECT_EQ(rig.node.eds_mismatch(eds), "");
  EXPECT_EQ(eds.identity.vendor_id, kControllerVendorId);
  EXPECT_EQ(eds.identity.product_code, kControllerProductCode);
  EXPECT_EQ(eds.identity.revision, (std::uint32_t{rig.version.major} << 16) | rig.version.minor)
      << "docs/eds/delta_fw.eds: RevisionNumber is the firmware's version";
  EXPECT_EQ(eds.find(0x1017, 0)->default_value(16), rig.config.heartbeat_ms);
}

// TPDO1-3 (the log frames) are mapped in 0x1A00-0x1A02 onto 0x2100-0x2102,
// which hold the latest record: a master that reads the mapping and the
// objects by SDO finds in them what the frames carry, every value at the
// bits the mapping says.
TEST(ControllerNodeTest, TheLogFramesMappingDescribesWhatTheyCarry) {
  NodeRig rig;
  rig.step();
  const p::LogPayloads frames =
      p::pack_log(1234, true, {1 << 20, -(1 << 19), 7}, {-3, 1 << 16, -(1 << 17)});
  rig.node.note_log_frames(frames.data);
  for (unsigned tpdo = 0; tpdo < 3; ++tpdo) {
    const auto mapping = static_cast<std::uint16_t>(0x1A00 + tpdo);
    ASSERT_EQ(rig.read(mapping, 0), 3u) << mapping;
    unsigned bit = 0;
    for (std::uint8_t k = 1; k <= 3; ++k) {
      const std::uint32_t entry = rig.read(mapping, k);
      const auto index = static_cast<std::uint16_t>(entry >> 16);
      const auto sub = static_cast<std::uint8_t>(entry >> 8);
      const unsigned bits = entry & 0xFF;
      std::uint64_t carried = 0;
      for (unsigned b = 0; b < bits; ++b) {
        const unsigned at = bit + b;
        carried |= std::uint64_t{(frames.data[tpdo][at / 8] >> (at % 8)) & 1u} << b;
      }
      EXPECT_EQ(rig.read(index, sub), carried)
          << "TPDO" << tpdo + 1 << " entry " << int{k} << ": 0x" << std::hex << entry;
      bit += bits;
    }
    EXPECT_EQ(bit, 64u) << "TPDO" << tpdo + 1;
  }
  // The values themselves: seq 1234 with the stale bit, q2 = -0.5 rad.
  EXPECT_EQ(rig.read(0x2100, 0), 1234u | 1u << 15);
  EXPECT_EQ(rig.read(0x2101, 2), static_cast<std::uint32_t>(-(1 << 19)) & 0xFFFFFFu);
  EXPECT_EQ(rig.read(0x2102, 3), static_cast<std::uint32_t>(-(1 << 17)) & 0xFFFFFFu);
}

}  // namespace
}  // namespace fw_linux
