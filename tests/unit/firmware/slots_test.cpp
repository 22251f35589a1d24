// The A/B slot machine (fw/update/slots.hpp): every transition of
// docs/flashing.md, the refusals, what a power loss at each point leaves,
// and the stored record's round trip and corruption checks.
#include "fw/update/slots.hpp"

#include <gtest/gtest.h>

namespace fw::update {
namespace {

BootRecord installed() {
  BootRecord r;
  r.slots[0] = {SlotState::kConfirmed, 0xAAAA0000u, {1, 0, 0}};
  return r;
}

// A record written and read back: what the supervisor sees after a restart.
BootRecord after_restart(const BootRecord& r) {
  RecordBytes b;
  encode(r, b);
  BootRecord back;
  EXPECT_TRUE(decode(b, back));
  return back;
}

TEST(SlotsTest, DownloadTrialConfirm) {
  Slots s(installed());
  EXPECT_EQ(s.boot().slot, 0);
  ASSERT_EQ(s.begin_download(), Refusal::kNone);
  EXPECT_EQ(s.record().slots[1].state, SlotState::kReceiving);
  ASSERT_EQ(s.end_download(Verdict::kOk, 0xBBBB0000u, {1, 1, 0}), Refusal::kNone);
  EXPECT_EQ(s.record().slots[1].state, SlotState::kStaged);
  EXPECT_EQ(s.record().slots[1].crc32, 0xBBBB0000u);
  ASSERT_EQ(s.start_trial(), Refusal::kNone);
  const Launch l = s.boot();
  EXPECT_EQ(l.slot, 1);
  EXPECT_TRUE(l.trial);
  EXPECT_EQ(s.begin_download(), Refusal::kTrialUnderWay);
  EXPECT_EQ(s.clear(), Refusal::kTrialUnderWay);
  ASSERT_EQ(s.confirm(), Refusal::kNone);
  EXPECT_EQ(s.active(), 1);
  EXPECT_EQ(s.record().slots[1].state, SlotState::kConfirmed);
  EXPECT_EQ(s.record().slots[0].state, SlotState::kConfirmed);  // the fallback
  const Launch next = s.boot();
  EXPECT_EQ(next.slot, 1);
  EXPECT_FALSE(next.trial);
  // The next download goes to the old slot.
  ASSERT_EQ(s.begin_download(), Refusal::kNone);
  EXPECT_EQ(s.record().slots[0].state, SlotState::kReceiving);
}

TEST(SlotsTest, ARefusedImageLeavesTheSpareEmptyAndSaysWhy) {
  Slots s(installed());
  ASSERT_EQ(s.begin_download(), Refusal::kNone);
  ASSERT_EQ(s.end_download(Verdict::kPayloadCrc, 0, {}), Refusal::kNone);
  EXPECT_EQ(s.record().slots[1].state, SlotState::kEmpty);
  EXPECT_EQ(s.record().last_verdict, Verdict::kPayloadCrc);
  EXPECT_EQ(s.start_trial(), Refusal::kNothingStaged);
  EXPECT_EQ(s.end_download(Verdict::kOk, 1, {}), Refusal::kNotReceiving);
  EXPECT_EQ(s.confirm(), Refusal::kNoTrial);
  EXPECT_EQ(s.trial_failed(RevertReason::kCrashed), Refusal::kNoTrial);
}

TEST(SlotsTest, AFailedTrialRevertsToTheActiveSlot) {
  for (const RevertReason why :
       {RevertReason::kNoConfirmation, RevertReason::kExited, RevertReason::kCrashed}) {
    Slots s(installed());
    (void)s.begin_download();
    (void)s.end_download(Verdict::kOk, 0xBBBB0000u, {1, 1, 0});
    (void)s.start_trial();
    ASSERT_TRUE(s.boot().trial);
    ASSERT_EQ(s.trial_failed(why), Refusal::kNone);
    EXPECT_EQ(s.record().slots[1].state, SlotState::kReverted);
    EXPECT_EQ(s.record().last_revert, why);
    EXPECT_EQ(s.boot().slot, 0);
    EXPECT_EQ(s.start_trial(), Refusal::kNothingStaged);  // a reverted program is not retried
  }
}

// A power loss at every step: the record as last stored, read back; the
// boot that follows must launch a slot that holds a confirmed program.
TEST(SlotsTest, APowerLossAtAnyStepLeavesABootableSlot) {
  Slots s(installed());
  std::vector<BootRecord> stored;
  stored.push_back(s.record());
  (void)s.begin_download();
  stored.push_back(s.record());
  (void)s.end_download(Verdict::kOk, 0xBBBB0000u, {1, 1, 0});
  stored.push_back(s.record());
  (void)s.start_trial();
  stored.push_back(s.record());  // trial asked, not launched: it is launched on boot
  (void)s.boot();
  stored.push_back(s.record());  // trial launched: a restart reverts it
  (void)s.confirm();
  stored.push_back(s.record());
  const RevertReason expected_revert[] = {RevertReason::kNone,      RevertReason::kNone,
                                          RevertReason::kNone,      RevertReason::kNone,
                                          RevertReason::kPowerLost, RevertReason::kNone};
  for (std::size_t i = 0; i < stored.size(); ++i) {
    Slots after(after_restart(stored[i]));
    const Launch l = after.boot();
    const SlotState st = after.record().slots[l.slot].state;
    if (l.trial) {
      EXPECT_EQ(i, 3u);
      EXPECT_EQ(st, SlotState::kTrial);
    } else {
      EXPECT_EQ(st, SlotState::kConfirmed) << i;
    }
    EXPECT_NE(after.record().slots[after.spare()].state, SlotState::kReceiving) << i;
    EXPECT_EQ(after.record().last_revert, expected_revert[i]) << i;
  }
}

TEST(SlotsTest, ClearEmptiesTheSpare) {
  Slots s(installed());
  (void)s.begin_download();
  (void)s.end_download(Verdict::kOk, 0xBBBB0000u, {1, 1, 0});
  ASSERT_EQ(s.clear(), Refusal::kNone);
  EXPECT_EQ(s.record().slots[1].state, SlotState::kEmpty);
  EXPECT_EQ(s.start_trial(), Refusal::kNothingStaged);
}

TEST(SlotsTest, TheRecordRoundTripsAndRefusesCorruption) {
  BootRecord r = installed();
  r.active = 1;
  r.trial_started = true;
  r.last_revert = RevertReason::kCrashed;
  r.last_verdict = Verdict::kBadSignature;
  r.slots[1] = {SlotState::kTrial, 0x12345678u, {2, 3, 4}};
  RecordBytes b;
  encode(r, b);
  BootRecord back;
  ASSERT_TRUE(decode(b, back));
  EXPECT_EQ(back.active, 1);
  EXPECT_TRUE(back.trial_started);
  EXPECT_EQ(back.last_revert, RevertReason::kCrashed);
  EXPECT_EQ(back.last_verdict, Verdict::kBadSignature);
  EXPECT_EQ(back.slots[1].state, SlotState::kTrial);
  EXPECT_EQ(back.slots[1].crc32, 0x12345678u);
  EXPECT_EQ(delta::update::compare(back.slots[1].version, {2, 3, 4}), 0);
  for (std::size_t i = 0; i < b.size(); ++i) {
    RecordBytes bad = b;
    bad[i] ^= 0x40;
    EXPECT_FALSE(decode(bad, back)) << "byte " << i;
  }
}

}  // namespace
}  // namespace fw::update
