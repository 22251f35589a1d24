// The emulated drive as a CiA 301/402 node, frame by frame: its SDO server
// (common's, over the drive's object dictionary), the objects CiA 402 makes
// mandatory, and what a node does in each NMT state. Each test here failed
// before its fix (#17's list of deviations).
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "delta/can/protocol.hpp"
#include "delta/can/sdo.hpp"
#include "delta/canopen/eds.hpp"
#include "emu/emulator.hpp"

namespace emu {
namespace {

namespace p = delta::can::protocol;
namespace sdo = delta::can::sdo;
using delta::can::Frame;

// One emulator with the lumped plant; the frames it sends are collected.
struct Bus {
  std::vector<Frame> out;
  Emulator emulator;
  std::uint64_t wall_us{1'000'000};

  explicit Bus(const EmulatorConfig& config = {})
      : emulator(config, [this](const Frame& f, std::uint32_t) { out.push_back(f); }) {
    emulator.boot();
  }

  void send(std::uint32_t id, std::uint8_t dlc, const std::array<std::uint8_t, 8>& data) {
    Frame f{};
    f.id = id;
    f.dlc = dlc;
    f.data = data;
    emulator.on_frame(f);
  }
  void nmt(std::uint8_t command, std::uint8_t node) {
    send(p::cob_id(p::kNmt, 0), 2, {command, node});
  }
  // One expedited or segmented request to node 1, and its answers.
  std::vector<sdo::Payload> ask(const sdo::Payload& request) {
    out.clear();
    send(p::cob_id(p::kSdoRx, 1), 8, request);
    std::vector<sdo::Payload> answers;
    for (const Frame& f : out) {
      if (f.id == p::cob_id(p::kSdoTx, 1)) answers.push_back(f.data);
    }
    return answers;
  }
  sdo::Payload ask_one(const sdo::Payload& request) {
    const std::vector<sdo::Payload> a = ask(request);
    EXPECT_EQ(a.size(), 1u);
    return a.empty() ? sdo::Payload{} : a.front();
  }
  std::uint32_t abort_code(const sdo::Payload& request) {
    const sdo::Payload r = ask_one(request);
    return r[0] == sdo::kAbort ? sdo::get_u32(r) : 0u;
  }
  std::uint32_t read(std::uint16_t index, std::uint8_t sub) {
    const sdo::Response r = sdo::parse_response(ask_one(sdo::upload_request(index, sub)));
    EXPECT_EQ(r.kind, sdo::ResponseKind::kUploadValue) << std::hex << index << ":" << int{sub};
    return r.value;
  }
  // A whole transfer with common's client, frame by frame.
  sdo::Client client;
  void run_client() {
    for (int guard = 0; guard < 10000 && client.status() == sdo::ClientStatus::kBusy; ++guard) {
      sdo::Payload request;
      if (!client.pending(request)) break;
      client.sent(wall_us);
      for (const sdo::Payload& answer : ask(request)) client.on_frame(answer, wall_us);
    }
  }
};

// CiA 301: a download of the wrong length is aborted with 0x06070012/13 and
// stores nothing (1 byte written to 0x1006 set all 4, and 0x6060 took 2 or 4
// bytes); a download without the size indicated takes the object's size; an
// upload answers with the object's own size (not always 4 bytes).
TEST(EmulatedDriveTest, SdoLengthsAreTheObjectsOwn) {
  Bus bus;
  const std::uint32_t cycle = bus.read(0x1006, 0);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1006, 0, 0x000007D0, 1)),
            sdo::kAbortLengthTooLow);
  EXPECT_EQ(bus.read(0x1006, 0), cycle);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x6060, 0, 10, 2)), sdo::kAbortLengthTooHigh);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x6060, 0, 10, 4)), sdo::kAbortLengthTooHigh);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1017, 0, 100, 1)), sdo::kAbortLengthTooLow);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1017, 0, 100, 4)), sdo::kAbortLengthTooHigh);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1017, 0, 100, 2)), 0u);
  sdo::Payload unsized = sdo::download_request(0x1017, 0, 120, 4);
  unsized[0] = 0x22;  // expedited, size not indicated
  EXPECT_EQ(bus.abort_code(unsized), 0u);
  EXPECT_EQ(bus.read(0x1017, 0), 120u);
  EXPECT_EQ(bus.ask_one(sdo::upload_request(0x1017, 0))[0], 0x4B);  // 2 bytes
  EXPECT_EQ(bus.ask_one(sdo::upload_request(0x6061, 0))[0], 0x4F);  // 1 byte
  EXPECT_EQ(bus.ask_one(sdo::upload_request(0x6041, 0))[0], 0x4B);
  EXPECT_EQ(bus.ask_one(sdo::upload_request(0x1001, 0))[0], 0x4F);
  EXPECT_EQ(bus.ask_one(sdo::upload_request(0x1000, 0))[0], 0x43);  // 4 bytes
}

TEST(EmulatedDriveTest, HasTheMandatoryObjectsWithTheirTypes) {
  Bus bus;
  EXPECT_EQ(bus.read(0x1018, 0), 4u);
  EXPECT_EQ(bus.read(0x1018, 1), kEmulatorVendorId);
  EXPECT_EQ(bus.read(0x1018, 2), kEmulatorProductCode);
  EXPECT_EQ(bus.read(0x1018, 3), kEmulatorRevision);
  EXPECT_EQ(bus.read(0x1018, 4), 0x00010001u);  // node 1
  EXPECT_EQ(bus.abort_code(sdo::upload_request(0x1018, 5)), sdo::kAbortSubindexDoesNotExist);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1018, 1, 1, 4)), sdo::kAbortReadOnly);
  EXPECT_EQ(bus.read(0x6502, 0), 1u << 9);                          // cyclic synchronous torque
  EXPECT_EQ(bus.ask_one(sdo::upload_request(0x6064, 0))[0], 0x43);  // INTEGER32
  EXPECT_EQ(bus.ask_one(sdo::upload_request(0x6071, 0))[0], 0x4B);  // INTEGER16
  EXPECT_EQ(bus.ask_one(sdo::upload_request(0x6078, 0))[0], 0x4B);  // INTEGER16
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x6071, 0, 0xFF9C, 2)), 0u);  // -100 per mille
  EXPECT_EQ(bus.read(0x6071, 0), 0xFF9Cu);
}

TEST(EmulatedDriveTest, TheDeviceNameUploadsInSegments) {
  Bus bus;
  std::vector<std::uint8_t> name(64);
  bus.client.upload(0x1008, 0, name, sdo::Transfer::kAuto, bus.wall_us);
  bus.run_client();
  ASSERT_EQ(bus.client.status(), sdo::ClientStatus::kDone)
      << sdo::abort_meaning(bus.client.abort_code());
  EXPECT_EQ(std::string(name.begin(), name.begin() + bus.client.uploaded_size()),
            "Delta emulated CiA 402 drive");
  bus.client.upload(0x1008, 0, name, sdo::Transfer::kBlock, bus.wall_us);
  bus.run_client();
  ASSERT_EQ(bus.client.status(), sdo::ClientStatus::kDone);
  EXPECT_EQ(bus.client.uploaded_size(), 28u);
}

// A master without PDOs can enable the drive through 0x6040.
TEST(EmulatedDriveTest, TheControlwordEnablesTheDriveBySdo) {
  Bus bus;
  for (const std::uint16_t cw :
       {std::uint16_t{0x0006}, std::uint16_t{0x0007}, std::uint16_t{0x000F}}) {
    EXPECT_EQ(bus.abort_code(sdo::download_request(0x6040, 0, cw, 2)), 0u);
  }
  EXPECT_EQ(bus.emulator.drive_state(0), delta::can::cia402::State::kOperationEnabled);
  EXPECT_EQ(bus.read(0x6041, 0) & 0x6F, 0x27u);
}

// CiA 301: reset communication sets the communication parameters back to
// their power-on values and keeps the application's; reset node sets both
// back and restarts the drive (power stage off). Each sends the boot-up.
TEST(EmulatedDriveTest, ResetCommunicationAndResetNodeRestoreTheirParameters) {
  Bus bus;
  const auto write = [&](std::uint16_t index, std::uint8_t sub, std::uint32_t v,
                         std::uint8_t size) {
    return bus.abort_code(sdo::download_request(index, sub, v, size));
  };
  const auto configure = [&] {
    EXPECT_EQ(write(0x1019, 0, 5, 1), 0u);
    EXPECT_EQ(write(0x1006, 0, 2000, 4), 0u);
    EXPECT_EQ(write(0x1017, 0, 100, 2), 0u);
    EXPECT_EQ(write(0x1016, 1, 0x00100096, 4), 0u);
    EXPECT_EQ(write(0x6060, 0, 10, 1), 0u);
    EXPECT_EQ(write(0x6073, 0, 1500, 2), 0u);
    for (const std::uint16_t cw :
         {std::uint16_t{0x0006}, std::uint16_t{0x0007}, std::uint16_t{0x000F}}) {
      EXPECT_EQ(write(0x6040, 0, cw, 2), 0u);
    }
  };
  const auto boot_ups = [&] {
    int n = 0;
    for (const Frame& f : bus.out) n += f.id == p::cob_id(p::kHeartbeat, 1) && f.data[0] == 0;
    return n;
  };
  // After each reset: one boot-up, the communication parameters at their
  // power-on values, and the application's as given.
  using delta::can::cia402::State;
  const auto expect_after = [&](std::uint8_t command, std::uint8_t target, std::uint32_t mode,
                                std::uint32_t max_current_pm, State state) {
    configure();
    bus.out.clear();
    bus.nmt(command, target);
    EXPECT_EQ(boot_ups(), 1);
    for (const auto& [index, sub] : {std::pair<std::uint16_t, std::uint8_t>{0x1006, 0},
                                     {0x1019, 0},
                                     {0x1017, 0},
                                     {0x1016, 1}}) {
      EXPECT_EQ(bus.read(index, sub), 0u) << std::hex << index << ":" << int{sub};
    }
    EXPECT_EQ(bus.read(0x6060, 0), mode);
    EXPECT_EQ(bus.read(0x6073, 0), max_current_pm);
    EXPECT_EQ(bus.emulator.drive_state(0), state);
  };
  // Reset communication keeps the application's parameters; reset node not.
  expect_after(p::kNmtResetCommunication, 1, 10, 1500, State::kOperationEnabled);
  expect_after(p::kNmtResetNode, 0, 0, 3000, State::kSwitchOnDisabled);
}

// CiA 301: in NMT stopped only NMT and error control; no SDO, no EMCY.
TEST(EmulatedDriveTest, AStoppedNodeAnswersNoSdoAndSendsNoEmcy) {
  EmulatorConfig config;
  config.faults = {parse_fault("overcurrent:1@0.01"), parse_fault("overcurrent:2@0.01")};
  Bus bus(config);
  bus.nmt(p::kNmtStop, 1);
  EXPECT_TRUE(bus.ask(sdo::upload_request(0x1000, 0)).empty());
  for (int i = 0; i < 10; ++i) bus.send(p::cob_id(p::kSync, 0), 0, {});
  EXPECT_EQ(bus.emulator.drive_state(0), delta::can::cia402::State::kFault);
  int emcy_1 = 0;
  int emcy_2 = 0;
  for (const Frame& f : bus.out) {
    emcy_1 += f.id == p::cob_id(p::kEmcy, 1) ? 1 : 0;
    emcy_2 += f.id == p::cob_id(p::kEmcy, 2) ? 1 : 0;
  }
  EXPECT_EQ(emcy_1, 0);
  EXPECT_EQ(emcy_2, 1);  // node 2, pre-operational, reports it
  bus.nmt(p::kNmtEnterPreOperational, 1);
  EXPECT_EQ(bus.read(0x1000, 0), delta::can::od::kDeviceTypeServo);
}

// The heartbeat is produced in every NMT state, also while SYNCs flow.
TEST(EmulatedDriveTest, APreOperationalDriveSendsItsHeartbeatWhileSyncsFlow) {
  Bus bus;
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1017, 0, 10, 2)), 0u);  // 10 ms
  bus.out.clear();
  for (int i = 0; i < 20; ++i) bus.send(p::cob_id(p::kSync, 0), 0, {});  // 40 ms of 2 ms cycles
  int heartbeats = 0;
  for (const Frame& f : bus.out) {
    if (f.id == p::cob_id(p::kHeartbeat, 1)) {
      ++heartbeats;
      EXPECT_EQ(f.data[0], p::kNmtStatePreOperational);
    }
  }
  EXPECT_GE(heartbeats, 3);
  EXPECT_LE(heartbeats, 5);
}

// The EDS the product ships for the emulated drive (docs/eds/) and the
// drive agree object by object: what the EDS lists answers with its size
// and access, and nothing answers that the EDS does not list.
// PDO mapping by SDO (CiA 301): the rules and their abort codes, and the
// PDOs following the mapping.
TEST(EmulatedDriveTest, APdoMappingIsChangedOnlyByCiA301sRulesAndThePdoFollowsIt) {
  Bus bus;
  const auto write = [&](std::uint16_t index, std::uint8_t sub, std::uint32_t v,
                         std::uint8_t size) {
    return bus.abort_code(sdo::download_request(index, sub, v, size));
  };
  // TPDO1 is on: its mapping is fixed.
  EXPECT_EQ(write(0x1A00, 0, 0, 1), sdo::kAbortValueRange);
  EXPECT_EQ(write(0x1800, 1, 0x80000185, 4), sdo::kAbortValueRange);  // another ID
  EXPECT_EQ(write(0x1800, 1, 0x80000181, 4), 0u);                     // off
  EXPECT_EQ(bus.read(0x1800, 1), 0x80000181u);
  EXPECT_EQ(write(0x1A00, 1, 0x60640020, 4), sdo::kAbortValueRange);  // entries while count 3
  EXPECT_EQ(write(0x1A00, 0, 0, 1), 0u);
  EXPECT_EQ(write(0x1A00, 1, 0x20000020, 4), sdo::kAbortObjectDoesNotExist);
  EXPECT_EQ(write(0x1A00, 1, 0x60730010, 4), sdo::kAbortNotMappable);            // max current
  EXPECT_EQ(write(0x1A00, 1, 0x60640010, 4), sdo::kAbortParameterIncompatible);  // 16 of 32 bits
  EXPECT_EQ(write(0x1600, 1, 0x60410010, 4), sdo::kAbortValueRange);             // RPDO1 is on
  EXPECT_EQ(write(0x1400, 1, 0x80000201, 4), 0u);
  EXPECT_EQ(write(0x1600, 0, 0, 1), 0u);
  EXPECT_EQ(write(0x1600, 1, 0x60410010, 4),
            sdo::kAbortNotMappable);  // read-only: not into an RPDO
  // Three 32-bit objects are 12 bytes: too long for a PDO.
  EXPECT_EQ(write(0x1A00, 1, 0x60640020, 4), 0u);
  EXPECT_EQ(write(0x1A00, 2, 0x606C0020, 4), 0u);
  EXPECT_EQ(write(0x1A00, 3, 0x607A0020, 4), 0u);
  EXPECT_EQ(write(0x1A00, 0, 3, 1), sdo::kAbortPdoLength);
  // Position then statusword: 6 bytes.
  EXPECT_EQ(write(0x1A00, 2, 0x60410010, 4), 0u);
  EXPECT_EQ(write(0x1A00, 0, 2, 1), 0u);
  EXPECT_EQ(write(0x1800, 1, 0x00000181, 4), 0u);
  EXPECT_EQ(write(0x1A00, 0, 1, 1), sdo::kAbortValueRange);  // on again: fixed
  const auto position = static_cast<std::int32_t>(bus.read(0x6064, 0));
  const auto statusword = bus.read(0x6041, 0);
  bus.nmt(p::kNmtStart, 1);
  bus.out.clear();
  bus.send(p::cob_id(p::kSync, 0), 0, {});
  const Frame* tpdo1 = nullptr;
  for (const Frame& f : bus.out) {
    if (f.id == p::cob_id(p::kTpdo1, 1)) tpdo1 = &f;
  }
  ASSERT_NE(tpdo1, nullptr);
  EXPECT_EQ(tpdo1->dlc, 6);
  EXPECT_EQ(static_cast<std::int32_t>(tpdo1->data[0] | tpdo1->data[1] << 8 | tpdo1->data[2] << 16 |
                                      tpdo1->data[3] << 24),
            position);
  EXPECT_EQ(std::uint32_t{tpdo1->data[4]} | std::uint32_t{tpdo1->data[5]} << 8, statusword);
}

// The arm-side encoder, CiA 402's additional position actual value
// 0x60E4:1, maps into TPDO4 (off and empty by default), which then goes on
// every SYNC at 0x480 + node. On the rigid default robot the arm is where
// the motor side is: the same count as 0x6064 (tests/hil's ElasticControl
// checks an elastic one's through the stiffness it gives).
TEST(EmulatedDriveTest, TheArmSideEncoderMapsIntoTpdo4) {
  Bus bus;
  const auto write = [&](std::uint16_t index, std::uint8_t sub, std::uint32_t v,
                         std::uint8_t size) {
    return bus.abort_code(sdo::download_request(index, sub, v, size));
  };
  EXPECT_EQ(bus.read(0x1803, 1), 0x80000481u);
  EXPECT_EQ(bus.read(0x1A03, 0), 0u);
  EXPECT_EQ(bus.read(0x60E4, 0), 1u);
  EXPECT_EQ(write(0x1A03, 1, 0x60E40008, 4), sdo::kAbortNotMappable);  // its count
  EXPECT_EQ(write(0x1A03, 1, 0x60E40120, 4), 0u);
  EXPECT_EQ(write(0x1A03, 0, 1, 1), 0u);
  EXPECT_EQ(write(0x1803, 1, 0x00000481, 4), 0u);
  bus.nmt(p::kNmtStart, 1);
  for (int cycle = 0; cycle < 3; ++cycle) {
    bus.out.clear();
    bus.send(p::cob_id(p::kSync, 0), 0, {});
    std::optional<Frame> tpdo4;
    for (const Frame& f : bus.out) {
      if (f.id == p::cob_id(p::kTpdo4, 1)) tpdo4 = f;
    }
    ASSERT_TRUE(tpdo4) << "cycle " << cycle;
    const auto position = static_cast<std::int32_t>(bus.read(0x6064, 0));
    EXPECT_EQ(static_cast<std::int32_t>(bus.read(0x60E4, 1)), position);
    EXPECT_EQ(tpdo4->dlc, 4);
    EXPECT_EQ(p::unpack(tpdo4->data, p::kTpdo4ArmPositionActual), position);
  }
}

// The second product's EDS gives another default mapping, which its
// PDOs follow until a master writes its own.
TEST(EmulatedDriveTest, AnEdsGivesTheDefaultMapping) {
  Bus bus;
  bus.emulator.set_product(
      product_of(delta::canopen::read_eds(DELTA_EDS_DIR "/delta_drive_emu_b.eds")));
  EXPECT_EQ(bus.read(0x1A00, 0), 2u);
  EXPECT_EQ(bus.read(0x1801, 1), 0x281u);  // TPDO2 on (node 1)
  bus.nmt(p::kNmtStart, 1);
  bus.out.clear();
  bus.send(p::cob_id(p::kSync, 0), 0, {});
  std::map<std::uint32_t, int> dlc;
  for (const Frame& f : bus.out) dlc[f.id] = f.dlc;
  EXPECT_EQ(dlc[p::cob_id(p::kTpdo1, 1)], 6);  // statusword, position
  EXPECT_EQ(dlc[p::cob_id(p::kTpdo2, 1)], 6);  // current, velocity
}

// An RPDO shorter than its mapping is not processed: EMCY 0x8210.
TEST(EmulatedDriveTest, AShortRpdoIsRefusedWithTheLengthEmergency) {
  Bus bus;
  bus.nmt(p::kNmtStart, 1);
  bus.out.clear();
  bus.send(p::cob_id(p::kRpdo1, 1), 4, {0x06, 0x00, 0x10, 0x00});
  ASSERT_EQ(bus.out.size(), 1u);
  EXPECT_EQ(bus.out[0].id, p::cob_id(p::kEmcy, 1));
  EXPECT_EQ(bus.out[0].data[0] | bus.out[0].data[1] << 8, 0x8210);
  EXPECT_EQ(bus.read(0x6040, 0), 0u);  // not taken
  bus.send(p::cob_id(p::kRpdo1, 1), 8, {0x06, 0x00, 0x10, 0x00, 0, 0, 0, 0});
  EXPECT_EQ(bus.read(0x6040, 0), 6u);
  EXPECT_EQ(bus.read(0x6071, 0), 16u);
}

// The SYNC counter (CiA 301, 0x1019): written only while 0x1006 is 0 and
// only 0 or 2..240; a SYNC of the other length draws EMCY 0x8240 once; TPDO3
// (0x2019) carries the counter of the SYNC its sample answers.
TEST(EmulatedDriveTest, TheSyncCounterIsConfiguredByCiA301sRulesAndEchoedInTpdo3) {
  Bus bus;
  const auto write = [&](std::uint16_t index, std::uint8_t sub, std::uint32_t v,
                         std::uint8_t size) {
    return bus.abort_code(sdo::download_request(index, sub, v, size));
  };
  EXPECT_EQ(write(0x1006, 0, 2000, 4), 0u);
  EXPECT_EQ(write(0x1019, 0, 5, 1), sdo::kAbortDeviceState);  // 0x1006 is not 0
  EXPECT_EQ(write(0x1006, 0, 0, 4), 0u);
  EXPECT_EQ(write(0x1019, 0, 1, 1), sdo::kAbortValueRange);
  EXPECT_EQ(write(0x1019, 0, 241, 1), sdo::kAbortValueRange);
  EXPECT_EQ(write(0x1019, 0, 5, 1), 0u);
  EXPECT_EQ(bus.read(0x1019, 0), 5u);
  EXPECT_EQ(write(0x1006, 0, 2000, 4), 0u);
  EXPECT_EQ(write(0x1802, 1, 0x00000381, 4), 0u);  // TPDO3 on
  bus.nmt(p::kNmtStart, 1);
  const auto sync = [&](std::uint8_t dlc, std::uint8_t counter) {
    bus.out.clear();
    bus.send(p::cob_id(p::kSync, 0), dlc, {counter});
    std::map<std::uint32_t, std::vector<Frame>> by_id;
    for (const Frame& f : bus.out) by_id[f.id].push_back(f);
    return by_id;
  };
  auto frames = sync(1, 3);
  ASSERT_EQ(frames[p::cob_id(p::kTpdo3, 1)].size(), 1u);
  EXPECT_EQ(frames[p::cob_id(p::kTpdo3, 1)][0].dlc, 1);
  EXPECT_EQ(frames[p::cob_id(p::kTpdo3, 1)][0].data[0], 3);
  EXPECT_TRUE(frames[p::cob_id(p::kEmcy, 1)].empty());
  EXPECT_EQ(bus.out.back().id, p::cob_id(p::kTpdo3, 1)) << "TPDO3 after TPDO1 and TPDO2";
  // A SYNC without the counter: EMCY 0x8240 (error register: communication), once.
  frames = sync(0, 0);
  ASSERT_EQ(frames[p::cob_id(p::kEmcy, 1)].size(), 1u);
  const Frame& emcy = frames[p::cob_id(p::kEmcy, 1)][0];
  EXPECT_EQ(emcy.data[0] | emcy.data[1] << 8, 0x8240);
  EXPECT_EQ(emcy.data[2], 0x10);
  EXPECT_TRUE(sync(0, 0)[p::cob_id(p::kEmcy, 1)].empty());
  EXPECT_TRUE(sync(1, 4)[p::cob_id(p::kEmcy, 1)].empty());
  EXPECT_EQ(sync(0, 0)[p::cob_id(p::kEmcy, 1)].size(), 1u) << "again after a right one";
  // Node 2 counts no SYNCs (0x1019 = 0): a SYNC with a byte is its error.
  EXPECT_EQ(sync(1, 1)[p::cob_id(p::kEmcy, 2)].size(), 1u);
}

class EmulatedDriveEdsTest : public ::testing::TestWithParam<const char*> {};

TEST_P(EmulatedDriveEdsTest, AgreesWithItsEdsObjectByObject) {
  namespace canopen = delta::canopen;
  const canopen::Eds eds = canopen::read_eds(std::string(DELTA_EDS_DIR "/") + GetParam());
  Bus bus;
  bus.emulator.set_product(product_of(eds));
  EXPECT_EQ(bus.emulator.eds_mismatch(eds), "");
  for (const auto& [key, v] : eds.variables) {
    SCOPED_TRACE(v.name);
    ASSERT_TRUE(canopen::readable(v.access));
    if (v.size_bytes() == 0) {  // a string: its whole text
      std::vector<std::uint8_t> text(256);
      bus.client.upload(v.index, v.subindex, text, sdo::Transfer::kAuto, bus.wall_us);
      bus.run_client();
      ASSERT_EQ(bus.client.status(), sdo::ClientStatus::kDone);
      text.resize(bus.client.uploaded_size());
      if (!v.default_text.empty()) {
        EXPECT_EQ(std::string(text.begin(), text.end()), v.default_text);
      }
      continue;
    }
    const sdo::Payload r = bus.ask_one(sdo::upload_request(v.index, v.subindex));
    ASSERT_NE(r[0], sdo::kAbort) << std::hex << v.index << ":" << int{v.subindex} << " "
                                 << sdo::abort_meaning(sdo::get_u32(r));
    EXPECT_EQ(r[0], 0x43 | ((4 - v.size_bytes()) << 2)) << "size of " << v.name;
    // Writing the value back: a read-only object refuses the access, a
    // writable one takes it or judges the value.
    const sdo::Payload w = sdo::download_request(v.index, v.subindex, sdo::get_u32(r),
                                                 static_cast<std::uint8_t>(v.size_bytes()));
    const std::uint32_t code = bus.abort_code(w);
    if (canopen::writable(v.access)) {
      EXPECT_NE(code, sdo::kAbortReadOnly) << v.name;
    } else {
      EXPECT_EQ(code, sdo::kAbortReadOnly) << v.name;
    }
    if (const auto value = v.default_value(1); value && !canopen::writable(v.access)) {
      EXPECT_EQ(sdo::get_u32(r), *value) << v.name << " differs from its DefaultValue";
    }
  }
  for (const std::uint32_t first : {0x1000u, 0x6000u}) {
    for (std::uint32_t index = first; index < first + 0x1000; ++index) {
      for (unsigned sub = 0; sub < 8; ++sub) {
        const auto i = static_cast<std::uint16_t>(index);
        const auto s = static_cast<std::uint8_t>(sub);
        const sdo::Payload r = bus.ask_one(sdo::upload_request(i, s));
        if (r[0] == 0x41) {  // a segmented upload begins: the client ends it
          EXPECT_TRUE(bus.ask(sdo::abort_transfer(i, s, sdo::kAbortGeneral)).empty());
        }
        const bool absent =
            r[0] == sdo::kAbort && (sdo::get_u32(r) == sdo::kAbortObjectDoesNotExist ||
                                    sdo::get_u32(r) == sdo::kAbortSubindexDoesNotExist);
        EXPECT_EQ(absent, eds.find(i, s) == nullptr) << std::hex << index << ":" << sub;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BothProducts, EmulatedDriveEdsTest,
                         ::testing::Values("delta_drive_emu.eds", "delta_drive_emu_b.eds"));

// delta_drive_emu --eds refuses an EDS that does not describe it, saying
// where they differ.
TEST(EmulatedDriveTest, AnEdsThatDoesNotDescribeTheDriveIsNamedWhereItDiffers) {
  namespace canopen = delta::canopen;
  Bus bus;
  const auto eds_text = [](const std::string& from, const std::string& to) {
    std::ifstream in(DELTA_EDS_DIR "/delta_drive_emu.eds");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text.replace(text.find(from), from.size(), to);
    return canopen::parse_eds(text, "x.eds");
  };
  EXPECT_EQ(
      bus.emulator.eds_mismatch(eds_text("DataType=0x0006\nAccessType=rw\nDefaultValue=3000",
                                         "DataType=0x0007\nAccessType=rw\nDefaultValue=3000")),
      "x.eds:395: 0x6073:00 (Max current) has 4 bytes; the emulated drive's has 2");
  EXPECT_EQ(bus.emulator.eds_mismatch(eds_text(
                "ParameterName=Max current\nObjectType=0x7\nDataType=0x0006\nAccessType=rw",
                "ParameterName=Max current\nObjectType=0x7\nDataType=0x0006\nAccessType=ro")),
            "x.eds:395: 0x6073:00 (Max current) is writable in the emulated drive");
  EXPECT_EQ(bus.emulator.eds_mismatch(eds_text("SupportedObjects=32\n", "SupportedObjects=31\n")),
            "x.eds: the emulated drive has object 0x60E4:00, which the EDS does not list");
  EXPECT_EQ(bus.emulator.eds_mismatch(
                eds_text("[ManufacturerObjects]\nSupportedObjects=1\n1=0x2019\n",
                         "[ManufacturerObjects]\nSupportedObjects=2\n1=0x2019\n2=0x2000\n"
                         "[2000]\nParameterName=Extra\nDataType=0x0007\n"
                         "AccessType=rw")),
            "x.eds:912: 0x2000:00 (Extra) is not an object of the emulated drive");
}

}  // namespace
}  // namespace emu

// delta_drive_emu --eds: the drive is exactly the EDS's objects, with
// their access, sizes, defaults and modes; anything else is refused with
// its CiA 301 abort code (tests/data/drives/epos4.eds: no 0x6078, no
// 0x608F; 0x6076 a writable setting; TPDOs at 255; 0x6502 without profile
// torque).
namespace emu {
namespace {

TEST(EmulatedVendorDriveTest, AnswersForExactlyTheObjectsOfItsEds) {
  Bus bus;
  bus.emulator.use_eds(delta::canopen::read_eds(DELTA_DRIVES_DIR "/epos4.eds"));
  EXPECT_EQ(bus.abort_code(sdo::upload_request(0x6078, 0)), sdo::kAbortObjectDoesNotExist);
  EXPECT_EQ(bus.abort_code(sdo::upload_request(0x608F, 1)), sdo::kAbortObjectDoesNotExist);
  EXPECT_EQ(bus.abort_code(sdo::upload_request(0x1018, 5)), sdo::kAbortSubindexDoesNotExist);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x6041, 0, 1, 2)), sdo::kAbortReadOnly);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1006, 0, 2000, 2)), sdo::kAbortLengthTooLow);
  EXPECT_EQ(bus.read(0x6502, 0), 0x000003A5u);
  EXPECT_EQ(bus.read(0x1800, 2), 255u);  // the vendor's transmission type
  EXPECT_EQ(bus.read(0x1018, 1), 0x000000FBu);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x6060, 0, 4, 1)), sdo::kAbortValueRange);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x6060, 0, 10, 1)), 0u);
  EXPECT_EQ(bus.read(0x6061, 0), 10u);
  // 0x6076, a setting (default 0 in the EDS): the emulated motor's until
  // written; 0 is refused. A manufacturer object of a DEFTYPE, which the
  // emulation keeps as a value: its default, then what is written.
  EXPECT_EQ(bus.read(0x6076, 0), 200u);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x6076, 0, 0, 4)), sdo::kAbortValueRange);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x6076, 0, 300, 4)), 0u);
  EXPECT_EQ(bus.read(0x6076, 0), 300u);
  EXPECT_EQ(bus.read(0x3000, 0), 0u);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x3000, 0, 7, 4)), 0u);
  EXPECT_EQ(bus.read(0x3000, 0), 7u);
  // 0x60C2 sets the cycle period like 0x1006.
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x60C2, 1, 4, 1)), 0u);
  EXPECT_EQ(bus.read(0x1006, 0), 4000u);
}

// A vendor's fixed PDO5s (tests/data/drives/fixed_pdo5.eds): read-only
// mappings; a COB-ID of its own (none predefined: RPDO5's default has
// none, TPDO5's is $NODEID+0x680, off) that moves only while the PDO is
// off (CiA 301); RPDO5 applied at its COB-ID, TPDO5 sent there at a SYNC.
TEST(EmulatedVendorDriveTest, FixedPdo5sMoveTheirCobIdOnlyWhileOff) {
  Bus bus;
  bus.emulator.use_eds(delta::canopen::read_eds(DELTA_DRIVES_DIR "/fixed_pdo5.eds"));
  EXPECT_EQ(bus.read(0x1804, 1), 0x80000681u);
  EXPECT_EQ(bus.read(0x1A04, 2), 0x60770010u);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1A04, 0, 0, 1)), sdo::kAbortReadOnly);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1804, 1, 0x80000481, 4)), 0u);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1804, 1, 0x481, 4)), 0u);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1804, 1, 0x482, 4)), sdo::kAbortValueRange);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1804, 2, 1, 1)), 0u);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1404, 1, 0x80000201, 4)), 0u);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1404, 1, 0x201, 4)), 0u);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1400, 1, 0x80000201, 4)), 0u);  // RPDO1 off
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x6060, 0, 10, 1)), 0u);
  bus.nmt(p::kNmtStart, 1);
  bus.send(0x201, 4, {0x06, 0x00, 0x00, 0x00});  // controlword: shutdown
  bus.out.clear();
  bus.send(p::cob_id(p::kSync, 0), 0, {});
  bool tpdo5 = false;
  for (const Frame& f : bus.out) {
    if (f.id == 0x481) {
      tpdo5 = true;
      EXPECT_EQ(f.dlc, 4);
      EXPECT_EQ(f.data[0] & 0x6F, 0x21) << "ready to switch on, after RPDO5's controlword";
    }
  }
  EXPECT_TRUE(tpdo5);
}

// A drive as the user commissioned it (delta_drive_emu --set, --config:
// the controller's own keys): its values take the place of the EDS's
// defaults, the controller's other keys are left to it, and a wrong value
// names its key and place.
TEST(EmulatedVendorDriveTest, TakesTheValuesItWasCommissionedWith) {
  const std::string conf = ::testing::TempDir() + "commissioned.conf";
  {
    std::ofstream out(conf);
    out << "# the controller's configuration\nperiod_us = 2000\njoint1.eds = epos4.eds\n"
           "joint1.rated_torque_Nm = 0.5   # the motor's\njoint2.counts_per_rev = 4096\n"
           "joint1.max_rad = 1.2\njoint3.torque_unit = mA\njoint2.inverted = yes\n"
           "approach_s = 3\n";
  }
  CommissionedDrives drives;
  drives.read_config(conf);
  EXPECT_TRUE(drives.set("joint1.rated_current_A=3", "--set"));
  EXPECT_FALSE(drives.set("limits.max_velocity_rad_s=3", "--set"));  // the controller's
  EXPECT_EQ(drives.taken,
            (std::vector<std::string>{"joint1.rated_torque_Nm=0.5", "joint2.counts_per_rev=4096",
                                      "joint3.torque_unit=mA", "joint2.inverted=yes",
                                      "approach_s=3", "joint1.rated_current_A=3"}));
  EXPECT_EQ(drives.approach_s, 3.0);
  // robot = FILE is the robot the emulator moves (its --robot).
  EXPECT_TRUE(drives.set("robot = robot.json", "delta.conf:9"));
  EXPECT_EQ(drives.robot, std::optional<std::string>("robot.json"));
  EXPECT_TRUE(drives.applied(1, {}).inverted);
  Bus bus;
  bus.emulator.use_eds(delta::canopen::read_eds(DELTA_DRIVES_DIR "/epos4.eds"));
  EXPECT_EQ(bus.read(0x6076, 0), 200u);  // the emulation's own, the EDS's default being 0
  bus.emulator.commission(drives);
  EXPECT_EQ(bus.read(0x6076, 0), 500u);
  const auto refused = [](const std::string& assignment) {
    CommissionedDrives d;
    try {
      d.set(assignment, "robot.conf:4");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(refused("joint2.rated_torque_Nm = -1"),
            "robot.conf:4: joint2.rated_torque_Nm: '-1' is not a number in (0, 10000]");
  EXPECT_EQ(refused("joint2.zero_rad = 4"),
            "robot.conf:4: joint2.zero_rad: '4' is not a number in [-3.14159, 3.14159]");
  EXPECT_EQ(refused("joint1.counts_per_rev=4096.5"),
            "robot.conf:4: joint1.counts_per_rev: '4096.5' is not a whole number of counts");
  EXPECT_EQ(refused("joint1.torque_unit=Nm"),
            "robot.conf:4: joint1.torque_unit: 'Nm' is not per_mille, mA or mNm");
}

// Transmission type 255 (event-driven): a TPDO goes when its data change,
// not on every SYNC; type 1 on every SYNC.
TEST(EmulatedVendorDriveTest, TransmissionTypesDecideWhenATpdoGoes) {
  Bus bus;
  bus.emulator.use_eds(delta::canopen::read_eds(DELTA_DRIVES_DIR "/epos4.eds"));
  bus.nmt(p::kNmtStart, 0);
  const auto tpdo1_count = [&bus](int syncs) {
    int n = 0;
    for (int i = 0; i < syncs; ++i) {
      bus.out.clear();
      bus.send(p::cob_id(p::kSync, 0), 0, {});
      for (const Frame& f : bus.out) n += f.id == 0x181;
    }
    return n;
  };
  EXPECT_EQ(tpdo1_count(10), 1) << "TPDO1 maps the statusword only, which does not change";
  bus.nmt(p::kNmtEnterPreOperational, 0);
  EXPECT_EQ(bus.abort_code(sdo::download_request(0x1800, 2, 1, 1)), 0u);
  bus.nmt(p::kNmtStart, 0);
  EXPECT_EQ(tpdo1_count(10), 10);
}

// A DCF's ParameterValue is the value the drive has.
TEST(EmulatedVendorDriveTest, ADcfsParameterValuesAreTheDrivesValues) {
  Bus bus;
  bus.emulator.use_eds(delta::canopen::read_eds(DELTA_DRIVES_DIR "/nanotec_pd4c.dcf"));
  EXPECT_EQ(bus.read(0x6075, 0), 2000u);
  EXPECT_EQ(bus.read(0x1800, 2), 0u);
}

}  // namespace
}  // namespace emu

namespace emu {
namespace {

// contact:FORCE_N:DX,DY,DZ:MS@SECONDS: the force along the normalised
// direction, its duration; malformed specs are refused with the reason,
// and the lumped plant (no platform body) refuses a contact at start.
TEST(EmulatedDriveTest, AContactIsParsedAndNeedsTheMultibodyPlant) {
  const FaultInjection f = parse_fault("contact:10:3,0,-4:200@2.5");
  EXPECT_EQ(f.kind, FaultKind::kContact);
  EXPECT_NEAR(f.force_N[0], 6.0, 1e-12);
  EXPECT_NEAR(f.force_N[1], 0.0, 1e-12);
  EXPECT_NEAR(f.force_N[2], -8.0, 1e-12);
  EXPECT_EQ(f.arg_ms, 200u);
  EXPECT_DOUBLE_EQ(f.at_s, 2.5);
  for (const char* bad : {"contact:10:0,0,0:200@1", "contact:-1:1,0,0:200@1",
                          "contact:10:1,0:200@1", "contact:10:1,0,0@1", "contact:10:1,0,0:0@1"}) {
    EXPECT_THROW((void)parse_fault(bad), std::invalid_argument) << bad;
  }
  EmulatorConfig lumped;
  lumped.faults = {f};
  EXPECT_THROW(Emulator(lumped, [](const delta::can::Frame&, std::uint32_t) {}),
               std::invalid_argument);
}

}  // namespace
}  // namespace emu
