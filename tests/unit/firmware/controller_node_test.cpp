// The controller's own CANopen node (node 16): boot-up and heartbeat, its
// SDO server and object dictionary (against docs/eds/delta_fw.eds), NMT
// commands, and emergencies.
#include "fw_linux/controller_node.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "delta/can/protocol.hpp"
#include "delta/controller/model_record.hpp"
#include "delta/little_endian.hpp"
#include "delta/model_q.hpp"
#include "delta/q_conversion.hpp"
#include "delta/update/crc32.hpp"
#include "fw_linux/collision_setting.hpp"
#include "node_rig.hpp"
#include "scratch_directory.hpp"

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

// A collision: the EMCY of fault 14, then TPDO4 once per joint with its
// residual and threshold in the log's 2^-16 N m, which 0x2103 holds (the
// last one) as the mapping 0x1A03 says; once, not every cycle in fault.
TEST(ControllerNodeTest, SendsTheCollisionsResidualsAndThresholdsAfterItsEmergency) {
  NodeRig rig;
  rig.step();
  rig.bus.take();
  fw::CollisionEvent e;
  e.joint = 1;
  e.residual_Nm = {delta::fx::Q12_19::from(0.01), delta::fx::Q12_19::from(-0.25),
                   delta::fx::Q12_19::from(0.002)};
  e.threshold_Nm = {delta::fx::Q12_19::from(0.05), delta::fx::Q12_19::from(0.125),
                    delta::fx::Q12_19::from(0.04)};
  rig.report.collision = &e;
  rig.step(fw::Fault::kCollision, 3);  // three cycles in fault: the frames once
  std::vector<Frame> collision;
  std::size_t emcy_at = 0, index = 0;
  for (const Frame& f : rig.bus.take()) {
    if (f.id == p::kControllerEmcy.base_id) emcy_at = index;
    if (f.id == p::kCollision.base_id) collision.push_back(f);
    ++index;
  }
  ASSERT_EQ(collision.size(), 3u);
  EXPECT_EQ(emcy_at, 0u);
  for (unsigned j = 0; j < 3; ++j) {
    EXPECT_EQ(collision[j].dlc, 8);
    EXPECT_EQ(p::unpack(collision[j].data, p::kCollisionJoint), j + 1);
    EXPECT_EQ(p::unpack(collision[j].data, p::kCollisionTripped), 2);
    EXPECT_EQ(p::unpack(collision[j].data, p::kCollisionResidual),
              std::llround(delta::to_double(e.residual_Nm[j]) * 65536.0));
    EXPECT_EQ(p::unpack(collision[j].data, p::kCollisionThreshold),
              std::llround(delta::to_double(e.threshold_Nm[j]) * 65536.0));
  }
  // Pre-operational (by NMT), then another collision: its EMCY goes out,
  // its frames (a TPDO) do not.
  rig.step();
  rig.nmt(p::kNmtEnterPreOperational, 0);
  rig.bus.take();
  rig.step(fw::Fault::kCollision);
  for (const Frame& f : rig.bus.take()) EXPECT_NE(f.id, p::kCollision.base_id);
  rig.nmt(p::kNmtStart, 0);
  EXPECT_EQ(rig.read(0x1803, 1), 0x490u);
  EXPECT_EQ(rig.read(0x1803, 2), 254u);
  EXPECT_EQ(rig.read(0x1A03, 3), 0x21030318u);
  EXPECT_EQ(rig.read(0x2103, 1), 3u);
  EXPECT_EQ(rig.read(0x2103, 2), 2u);
  EXPECT_EQ(rig.read(0x2103, 4), static_cast<std::uint32_t>(
                                     std::llround(delta::to_double(e.threshold_Nm[2]) * 65536.0)));
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

// TPDO5 and TPDO6 (LOG_D, LOG_E) are mapped in 0x1A04-0x1A05 onto 0x2100
// and 0x2104, the latest record's arm angles; their COB-IDs are valid only
// with arm_encoders = true (bit 31 set: the PDO does not exist on the bus).
TEST(ControllerNodeTest, TheArmLogFramesMappingDescribesWhatTheyCarry) {
  PortConfig c = NodeRig::unstored();
  EXPECT_EQ(NodeRig(std::nullopt, c).read(0x1804, 1), 0x800001D0u);
  c.arm_encoders = true;
  NodeRig rig(std::nullopt, c);
  rig.step();
  EXPECT_EQ(rig.read(0x1804, 1), 0x1D0u);
  EXPECT_EQ(rig.read(0x1805, 1), 0x2D0u);
  const p::ArmLogPayloads frames = p::pack_arm_log(77, false, {1 << 20, -(1 << 18), 5});
  rig.node.note_log_frames(p::pack_log(77, false, {}, {}).data);  // the same record's
  rig.node.note_arm_log_frames(frames.data);
  const unsigned counts[2] = {3, 2};
  for (unsigned tpdo = 0; tpdo < 2; ++tpdo) {
    const auto mapping = static_cast<std::uint16_t>(0x1A04 + tpdo);
    ASSERT_EQ(rig.read(mapping, 0), counts[tpdo]) << mapping;
    unsigned bit = 0;
    for (std::uint8_t k = 1; k <= counts[tpdo]; ++k) {
      const std::uint32_t entry = rig.read(mapping, k);
      const unsigned bits = entry & 0xFF;
      std::uint64_t carried = 0;
      for (unsigned b = 0; b < bits; ++b) {
        const unsigned at = bit + b;
        carried |= std::uint64_t{(frames.data[tpdo][at / 8] >> (at % 8)) & 1u} << b;
      }
      EXPECT_EQ(
          rig.read(static_cast<std::uint16_t>(entry >> 16), static_cast<std::uint8_t>(entry >> 8)),
          carried)
          << "TPDO" << tpdo + 5 << " entry " << int{k} << ": 0x" << std::hex << entry;
      bit += bits;
    }
    EXPECT_EQ(bit, 8u * (tpdo == 0 ? p::kLogD.dlc : p::kLogE.dlc)) << "TPDO" << tpdo + 5;
  }
  EXPECT_EQ(rig.read(0x2104, 2), static_cast<std::uint32_t>(-(1 << 18)) & 0xFFFFFFu);
  EXPECT_EQ(rig.read(0x2104, 3), 5u);
}

}  // namespace
}  // namespace fw_linux

namespace fw_linux {
namespace {

namespace mc = delta::controller;

// The default robot's model as host_id model load sends it.
mc::ModelRecordBytes model_bytes(double platform_mass_kg, const delta::Geometry& g,
                                 std::uint32_t fit_id) {
  delta::IdentifiedModel m;
  m.kind = "lumped";
  m.geometry = g;
  delta::LumpedParameters lumped = delta::default_lumped_parameters();
  lumped.platform_mass_kg = platform_mass_kg;
  m.parameters = delta::to_high_fidelity(lumped);
  m.fit_id = fit_id;
  mc::ModelRecordBytes bytes{};
  mc::encode_model_record(delta::model_record(m), bytes);
  return bytes;
}

PortConfig stored_in(const std::string& path) {
  PortConfig c = NodeRig::unstored();
  c.feed_forward_store = path;
  return c;
}

// Writes 0x2200:1 whole; the abort code (0: none).
sdo::AbortCode load(NodeRig& rig, std::span<const std::uint8_t> bytes) {
  rig.client.download(0x2200, 1, bytes, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  return rig.client.status() == sdo::ClientStatus::kDone ? sdo::kNoAbort : rig.client.abort_code();
}

// host_id model load's path: the record written by SDO, checked whole,
// stored atomically, in use at once (mode model), given back on a read,
// and in use again after a restart.
TEST(ControllerNodeTest, LoadsAModelOverSdoKeepsItAndGivesItBack) {
  const std::string store = testsupport::process_scratch("node_test").file("model_loads.bin");
  NodeRig rig(std::nullopt, stored_in(store));
  rig.step();
  EXPECT_EQ(rig.read(0x2200, 3), 1u);  // nominal
  EXPECT_EQ(rig.read(0x2200, 2), 0u);  // no model
  const auto bytes = model_bytes(0.45, delta::kDefaultGeometry, 0x12345678u);
  ASSERT_EQ(load(rig, bytes), sdo::kNoAbort) << sdo::abort_meaning(rig.client.abort_code());
  EXPECT_EQ(rig.read(0x2200, 2), 0x12345678u);
  EXPECT_EQ(rig.read(0x2200, 3), 2u);  // model
  EXPECT_EQ(rig.read(0x2200, 4), 0u);
  EXPECT_EQ(rig.feed_forward.current().mode, fw::FeedForwardMode::kModel);
  EXPECT_EQ(rig.feed_forward.current().model.parameters.platform_inertial_mass_kg.raw(),
            delta::fx::Q7_24::from(0.45).raw());
  std::vector<std::uint8_t> back(mc::kModelRecordBytes);
  rig.client.upload(0x2200, 1, back, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  ASSERT_EQ(rig.client.status(), sdo::ClientStatus::kDone);
  back.resize(rig.client.uploaded_size());
  EXPECT_EQ(back, std::vector<std::uint8_t>(bytes.begin(), bytes.end()));
  // Back to nominal and to model again by 0x2200:3, between runs.
  rig.client.download(0x2200, 3, std::vector<std::uint8_t>{1}, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  EXPECT_EQ(rig.read(0x2200, 3), 1u);
  // A restart: the stored model is in use again.
  NodeRig again(std::nullopt, stored_in(store));
  EXPECT_EQ(again.feed_forward.current().mode, fw::FeedForwardMode::kModel);
  EXPECT_EQ(again.feed_forward.fit_id(), 0x12345678u);
  EXPECT_NE(again.feed_forward.startup_note().find("loaded over the bus and kept in " + store),
            std::string::npos)
      << again.feed_forward.startup_note();
}

// Every refusal leaves the model in use as it was, and 0x2200:4 says why:
// another robot's model, a damaged record, a load during a run, a transfer
// that stops halfway (a lost frame, the tool killed).
TEST(ControllerNodeTest, ARefusedOrUnfinishedLoadLeavesTheModelInUse) {
  const std::string store = testsupport::process_scratch("node_test").file("model_refusals.bin");
  NodeRig rig(std::nullopt, stored_in(store));
  rig.step();
  const auto good = model_bytes(0.40, delta::kDefaultGeometry, 0xAAAA0001u);
  ASSERT_EQ(load(rig, good), sdo::kNoAbort);
  const auto in_use = [&] { return rig.read(0x2200, 2); };

  delta::Geometry other = delta::kDefaultGeometry;
  other.upper_arm_length_m = 0.25;
  EXPECT_EQ(load(rig, model_bytes(0.5, other, 0xBBBB0002u)), sdo::kAbortParameterIncompatible);
  EXPECT_EQ(rig.read(0x2200, 4), 6u);
  EXPECT_EQ(in_use(), 0xAAAA0001u);

  auto damaged = model_bytes(0.5, delta::kDefaultGeometry, 0xBBBB0003u);
  damaged[40] ^= 0x01;
  EXPECT_EQ(load(rig, damaged), sdo::kAbortCannotStore);
  EXPECT_EQ(rig.read(0x2200, 4), 3u);
  EXPECT_EQ(in_use(), 0xAAAA0001u);

  rig.report.safe_to_update = false;  // a trajectory runs
  rig.step();
  EXPECT_EQ(load(rig, model_bytes(0.5, delta::kDefaultGeometry, 0xBBBB0004u)),
            sdo::kAbortDeviceState);
  EXPECT_EQ(rig.read(0x2200, 4), 7u);
  EXPECT_EQ(in_use(), 0xAAAA0001u);
  rig.report.safe_to_update = true;
  rig.step();

  // Halfway: the client stops sending segments; the server times out.
  const auto next = model_bytes(0.5, delta::kDefaultGeometry, 0xBBBB0005u);
  rig.client.download(0x2200, 1, next, sdo::Transfer::kAuto, rig.now_us);
  for (int i = 0; i < 6; ++i) {
    sdo::Payload request;
    ASSERT_TRUE(rig.client.pending(request));
    rig.client.sent(rig.now_us);
    rig.frame(p::cob_id(p::kSdoRx, p::kControllerNode), 8, request);
    for (const Frame& f : rig.bus.take()) {
      if (f.id == p::cob_id(p::kSdoTx, p::kControllerNode)) rig.client.on_frame(f.data, rig.now_us);
    }
  }
  rig.client.cancel(sdo::kAbortTimeout);  // the tool is gone
  rig.step(fw::Fault::kNone, 1000);       // two seconds: the server gave up
  rig.client = sdo::Client();
  EXPECT_EQ(in_use(), 0xAAAA0001u);
  EXPECT_EQ(rig.feed_forward.current().model.parameters.platform_inertial_mass_kg.raw(),
            delta::fx::Q7_24::from(0.40).raw());
  // The store still holds the model in use; a whole load goes through.
  NodeRig restarted(std::nullopt, stored_in(store));
  EXPECT_EQ(restarted.feed_forward.fit_id(), 0xAAAA0001u);
  EXPECT_EQ(load(rig, next), sdo::kNoAbort);
  EXPECT_EQ(in_use(), 0xBBBB0005u);
  // Mode model needs a model; a mode that is none of the three is refused.
  NodeRig bare;
  bare.step();
  bare.client.download(0x2200, 3, std::vector<std::uint8_t>{2}, sdo::Transfer::kAuto, bare.now_us);
  bare.transfer();
  EXPECT_EQ(bare.client.abort_code(), sdo::kAbortValueRange);
  EXPECT_EQ(bare.read(0x2200, 3), 1u);
}

// The collision thresholds travel with the model (delta-model/2): loaded,
// they are the slot's, and given back; a negative one is refused as a
// value out of range; a delta-model/1 record (140 bytes, from before) is
// still taken, without thresholds.
TEST(ControllerNodeTest, AModelCarriesItsCollisionThresholds) {
  NodeRig rig;
  rig.step();
  delta::IdentifiedModel m;
  m.kind = "lumped";
  m.geometry = delta::kDefaultGeometry;
  m.parameters = delta::to_high_fidelity(delta::default_lumped_parameters());
  m.fit_id = 0xC0111DE5u;
  m.collision_thresholds =
      delta::CollisionThresholds{{0.04, 0.05, 0.06}, {0.1, 0.1, 0.2}, {0, 0.01, 0}};
  mc::ModelRecordBytes bytes{};
  mc::encode_model_record(delta::model_record(m), bytes);
  ASSERT_EQ(load(rig, bytes), sdo::kNoAbort) << sdo::abort_meaning(rig.client.abort_code());
  ASSERT_TRUE(rig.feed_forward.thresholds().has_value());
  EXPECT_EQ(rig.feed_forward.thresholds()->base_Nm[2].raw(), delta::fx::Q12_19::from(0.06).raw());
  EXPECT_EQ(rig.feed_forward.thresholds()->per_speed_Nm_s_per_rad[2].raw(),
            delta::fx::Q12_19::from(0.2).raw());
  mc::ModelRecord back;
  ASSERT_EQ(mc::decode_model_record(rig.feed_forward.record(), back), mc::ModelRecordFault::kOk);
  EXPECT_TRUE(back.has_collision_thresholds);
  EXPECT_EQ(back.collision_thresholds, *rig.feed_forward.thresholds());

  m.collision_thresholds->base_Nm[1] = -0.01;
  mc::encode_model_record(delta::model_record(m), bytes);
  EXPECT_EQ(load(rig, bytes), sdo::kAbortValueRange);
  EXPECT_EQ(rig.read(0x2200, 4), 5u);
  EXPECT_EQ(rig.read(0x2200, 2), 0xC0111DE5u);

  // Version 1: the same bytes up to the parameters, its CRC at 136.
  m.collision_thresholds.reset();
  m.fit_id = 0x0000F001u;
  mc::encode_model_record(delta::model_record(m), bytes);
  std::vector<std::uint8_t> v1(bytes.begin(), bytes.begin() + mc::kModelRecordV1Bytes);
  v1[4] = 1;
  delta::put_le32(v1, 136, delta::update::crc32(std::span<const std::uint8_t>(v1.data(), 136)));
  ASSERT_EQ(load(rig, v1), sdo::kNoAbort) << sdo::abort_meaning(rig.client.abort_code());
  EXPECT_EQ(rig.read(0x2200, 2), 0x0000F001u);
  EXPECT_FALSE(rig.feed_forward.thresholds().has_value());
  EXPECT_EQ(
      std::vector<std::uint8_t>(rig.feed_forward.record().begin(), rig.feed_forward.record().end()),
      v1);

  // Version 3 carries the gearboxes' compliances; version 2 (200 bytes, its
  // CRC at 196) has none: a rigid model.
  m.gearbox_compliance_rad_per_Nm = {1.0 / 3000, 1.0 / 3400, 1.0 / 2700};
  mc::encode_model_record(delta::model_record(m), bytes);
  ASSERT_EQ(load(rig, bytes), sdo::kNoAbort) << sdo::abort_meaning(rig.client.abort_code());
  EXPECT_EQ(rig.feed_forward.current().model.parameters.gearbox_compliance_rad_per_Nm[2].raw(),
            delta::fx::Q1_30::from(1.0 / 2700).raw());
  std::vector<std::uint8_t> v2(bytes.begin(), bytes.begin() + mc::kModelRecordV2Bytes);
  v2[4] = 2;
  delta::put_le32(v2, 196, delta::update::crc32(std::span<const std::uint8_t>(v2.data(), 196)));
  ASSERT_EQ(load(rig, v2), sdo::kNoAbort) << sdo::abort_meaning(rig.client.abort_code());
  EXPECT_EQ(rig.feed_forward.current().model.parameters.gearbox_compliance_rad_per_Nm,
            (std::array<delta::fx::Q1_30, 3>{}));
  // A stiffness below 64 N m/rad is no gearbox: refused as out of range.
  m.gearbox_compliance_rad_per_Nm[1] = 1.0 / 60;
  mc::encode_model_record(delta::model_record(m), bytes);
  EXPECT_EQ(load(rig, bytes), sdo::kAbortValueRange);
  EXPECT_EQ(rig.read(0x2200, 4), 5u);
}

// Every load and mode change over the bus is said, taken or refused (who
// may load a model: docs/security.md): a load during a run is refused
// (0x08000022) and said with why.
TEST(ControllerNodeTest, EveryLoadOverTheBusIsSaidTakenOrRefused) {
  NodeRig rig;
  std::vector<std::string> said;
  rig.feed_forward.set_report([&said](const std::string& s) { said.push_back(s); });
  rig.step();
  const auto bytes = model_bytes(0.45, delta::kDefaultGeometry, 0x0000AB12u);
  ASSERT_EQ(load(rig, bytes), sdo::kNoAbort) << sdo::abort_meaning(rig.client.abort_code());
  ASSERT_EQ(said.size(), 1u);
  EXPECT_EQ(said[0],
            "model fit 0x0000AB12 loaded over the bus (SDO download to node 16, 0x2200:1); the "
            "feed-forward from the next run on");
  rig.report.safe_to_update = false;  // a run is on
  rig.step();
  EXPECT_EQ(load(rig, bytes), 0x08000022u);
  ASSERT_EQ(said.size(), 2u);
  EXPECT_NE(said[1].find("was refused: a trajectory is running (models change between runs) "
                         "(0x2200:4 = 7); the model in use stays"),
            std::string::npos)
      << said[1];
  rig.report.safe_to_update = true;
  rig.step();
  rig.client.download(0x2200, 3, std::vector<std::uint8_t>{1}, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  ASSERT_EQ(said.size(), 3u);
  EXPECT_EQ(said[2], "feed-forward nominal asked over the bus (0x2200:3): from the next run on");
}

// With collision.detect = true, a load or a mode that would leave the
// detector without the model or its thresholds is refused (0x06040043,
// 0x2200:4 = 9) and nothing is stored; a model with thresholds goes in.
TEST(ControllerNodeTest, DetectTrueRefusesAModelWithoutThresholds) {
  const std::string store = testsupport::process_scratch("node_test").file("model_detect.bin");
  PortConfig c = stored_in(store);
  c.collision_detect = true;
  NodeRig rig(std::nullopt, c);
  rig.feed_forward.set_check(
      [c](const fw::FeedForwardConfig& f, const std::optional<fw::CollisionThresholds>& t) {
        return collision_check(c, f, t);
      });
  rig.step();
  EXPECT_EQ(load(rig, model_bytes(0.45, delta::kDefaultGeometry, 0x0000BAD1u)),
            sdo::kAbortParameterIncompatible);
  EXPECT_EQ(rig.read(0x2200, 4), 9u);
  EXPECT_EQ(rig.read(0x2200, 2), 0u);
  EXPECT_FALSE(std::ifstream(store).good()) << "nothing stored";
  delta::IdentifiedModel m;
  m.kind = "lumped";
  m.geometry = delta::kDefaultGeometry;
  m.parameters = delta::to_high_fidelity(delta::default_lumped_parameters());
  m.fit_id = 0x0000600Du;
  m.collision_thresholds = delta::CollisionThresholds{{0.05, 0.05, 0.05}, {}, {}};
  mc::ModelRecordBytes bytes{};
  mc::encode_model_record(delta::model_record(m), bytes);
  ASSERT_EQ(load(rig, bytes), sdo::kNoAbort) << sdo::abort_meaning(rig.client.abort_code());
  EXPECT_EQ(rig.read(0x2200, 2), 0x0000600Du);
  // Nominal would leave the detector without its model.
  rig.client.download(0x2200, 3, std::vector<std::uint8_t>{1}, sdo::Transfer::kAuto, rig.now_us);
  rig.transfer();
  EXPECT_EQ(rig.client.abort_code(), sdo::kAbortParameterIncompatible);
  EXPECT_EQ(rig.read(0x2200, 3), 2u);
}

}  // namespace
}  // namespace fw_linux
