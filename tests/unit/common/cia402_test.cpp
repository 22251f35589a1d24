#include "delta/can/cia402.hpp"

#include <gtest/gtest.h>

#include "delta/can/emcy.hpp"

namespace delta::can {
namespace {

using cia402::State;

TEST(Cia402Test, StatuswordsDecodeToTheirStates) {
  for (State s : {State::kNotReadyToSwitchOn, State::kSwitchOnDisabled, State::kReadyToSwitchOn,
                  State::kSwitchedOn, State::kOperationEnabled, State::kQuickStopActive,
                  State::kFaultReactionActive, State::kFault}) {
    // Other bits (e.g. warning, remote, target reached) do not change the state.
    EXPECT_EQ(cia402::decode_statusword(cia402::encode_statusword(s) | 0x0680), s);
  }
  EXPECT_EQ(cia402::decode_statusword(0x0237), State::kOperationEnabled);  // a typical drive's word
  EXPECT_EQ(cia402::decode_statusword(0x0218), State::kFault);
}

// The controller's side drives the drive's side: from any state to enabled
// and back, and through a fault reset.
State settle(State drive, bool enable, int max_cycles, int& cycles) {
  std::uint16_t cw = 0;
  for (cycles = 0; cycles < max_cycles; ++cycles) {
    const std::uint16_t next = cia402::controlword_towards(drive, enable, cw);
    drive = cia402::drive_transition(drive, next, cw);
    cw = next;
    if (drive == (enable ? State::kOperationEnabled : State::kSwitchOnDisabled)) return drive;
  }
  return drive;
}

TEST(Cia402Test, TheControllerEnablesADriveInThreeStepsAndDisablesItInOne) {
  int cycles = 0;
  EXPECT_EQ(settle(State::kSwitchOnDisabled, true, 10, cycles), State::kOperationEnabled);
  EXPECT_EQ(cycles, 2);  // shutdown, switch on, enable operation (0-based count)
  EXPECT_EQ(settle(State::kOperationEnabled, false, 10, cycles), State::kSwitchOnDisabled);
  EXPECT_EQ(cycles, 0);
  EXPECT_EQ(settle(State::kNotReadyToSwitchOn, true, 10, cycles), State::kOperationEnabled);
}

TEST(Cia402Test, AFaultNeedsAResetEdgeBeforeTheDriveCanBeEnabledAgain) {
  State s = cia402::drive_transition(State::kOperationEnabled, cia402::kEnableOperation, 0);
  EXPECT_EQ(s, State::kOperationEnabled);
  s = State::kFaultReactionActive;  // the drive detects a fault
  s = cia402::drive_transition(s, cia402::kEnableOperation, cia402::kEnableOperation);
  EXPECT_EQ(s, State::kFault);
  // Holding the reset bit high is not an edge.
  EXPECT_EQ(cia402::drive_transition(State::kFault, 0x80, 0x80), State::kFault);
  int cycles = 0;
  EXPECT_EQ(settle(State::kFault, true, 10, cycles), State::kOperationEnabled);
}

TEST(Cia402Test, QuickStopAndDisableOperation) {
  EXPECT_EQ(cia402::drive_transition(State::kOperationEnabled, cia402::kQuickStop, 0x0F),
            State::kQuickStopActive);
  EXPECT_EQ(cia402::drive_transition(State::kQuickStopActive, cia402::kDisableVoltage, 0x02),
            State::kSwitchOnDisabled);
  EXPECT_EQ(cia402::drive_transition(State::kOperationEnabled, cia402::kSwitchOn, 0x0F),
            State::kSwitchedOn);
}

TEST(SdoTest, ExpeditedTransfersEncodeAndDecode) {
  const auto d = sdo::download_request(0x6060, 0, 10, 1);  // modes of operation = CST
  EXPECT_EQ(d[0], 0x2F);
  EXPECT_EQ(d[1], 0x60);
  EXPECT_EQ(d[2], 0x60);
  EXPECT_EQ(d[4], 10);
  EXPECT_EQ(sdo::download_request(0x1017, 0, 100, 2)[0], 0x2B);
  EXPECT_EQ(sdo::download_request(0x6071, 0, 0xFFFFFFFF, 4)[0], 0x23);

  auto r = sdo::parse_response(sdo::download_response(0x6060, 0));
  EXPECT_EQ(r.kind, sdo::ResponseKind::kDownloadDone);
  EXPECT_EQ(r.index, 0x6060);
  r = sdo::parse_response(sdo::upload_response(0x1000, 0, 0x00020192));
  EXPECT_EQ(r.kind, sdo::ResponseKind::kUploadValue);
  EXPECT_EQ(r.value, 0x00020192u);
  r = sdo::parse_response(sdo::abort_transfer(0x2000, 3, sdo::kAbortObjectDoesNotExist));
  EXPECT_EQ(r.kind, sdo::ResponseKind::kAborted);
  EXPECT_EQ(r.value, sdo::kAbortObjectDoesNotExist);
  EXPECT_EQ(r.subindex, 3);
  // A 1-byte upload (0x4F) masks the unused bytes.
  sdo::Payload one = sdo::upload_response(0x6061, 0, 0xAABBCC0A);
  one[0] = 0x4F;
  EXPECT_EQ(sdo::parse_response(one).value, 0x0Au);
  sdo::Payload junk{};
  junk[0] = 0x21;  // a segmented transfer: not supported here
  EXPECT_EQ(sdo::parse_response(junk).kind, sdo::ResponseKind::kUnexpected);
}

// CiA 301's table: the specific communication codes, then the class of
// a code no entry names; a code outside every class says so.
TEST(EmcyMeaningTest, NamesTheMostSpecificEntryOfCia301sTable) {
  EXPECT_STREQ(od::emcy_meaning(0x0000), "error reset or no error");
  EXPECT_STREQ(od::emcy_meaning(od::kEmcyHeartbeat), "life guard or heartbeat error");
  EXPECT_STREQ(od::emcy_meaning(od::kEmcySyncLength), "unexpected SYNC data length");
  EXPECT_STREQ(od::emcy_meaning(od::kEmcyPdoLength), "PDO not processed due to length error");
  EXPECT_STREQ(od::emcy_meaning(0x8212), "PDO not processed due to length error");  // PDO 2
  EXPECT_STREQ(od::emcy_meaning(0x8251), "RPDO timeout");
  EXPECT_STREQ(od::emcy_meaning(0x8160), "communication");
  EXPECT_STREQ(od::emcy_meaning(0x8300), "monitoring");
  EXPECT_STREQ(od::emcy_meaning(od::kEmcyOvercurrent), "continuous over-current");
  EXPECT_STREQ(od::emcy_meaning(0x2311), "current, device output side");
  EXPECT_STREQ(od::emcy_meaning(0x2400), "current");
  EXPECT_STREQ(od::emcy_meaning(0x4210), "device temperature");
  EXPECT_STREQ(od::emcy_meaning(od::kEmcyUpdateRolledBack), "user software");
  EXPECT_STREQ(od::emcy_meaning(0x9001), "external error");
  EXPECT_STREQ(od::emcy_meaning(od::kEmcyControllerFaultBase + 2), "device specific");
  EXPECT_STREQ(od::emcy_meaning(0xF001), "additional functions");
  EXPECT_STREQ(od::emcy_meaning(0xA000), "not a CiA 301 error code");
  EXPECT_STREQ(od::emcy_meaning(0xF100), "not a CiA 301 error code");
}

}  // namespace
}  // namespace delta::can
