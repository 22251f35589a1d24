// The log assembler without a bus: pairing, wrap-around, reordering, loss.
#include "host_id/recorder.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "delta/can/protocol.hpp"

namespace host_id {
namespace {

namespace p = delta::can::protocol;

// The three log frames of one cycle, as the controller sends them.
std::array<delta::can::Frame, 3> log_frames(std::uint32_t seq, const std::array<double, 3>& q,
                                            const std::array<double, 3>& tau, bool stale = false) {
  std::array<std::int32_t, 3> q_raw{};
  std::array<std::int32_t, 3> tau_raw{};
  for (unsigned j = 0; j < 3; ++j) {
    q_raw[j] = static_cast<std::int32_t>(std::llround(q[j] * 1048576.0));
    tau_raw[j] = static_cast<std::int32_t>(std::llround(tau[j] * 65536.0));
  }
  const p::LogPayloads payloads = p::pack_log(seq, stale, q_raw, tau_raw);
  std::array<delta::can::Frame, 3> f{};
  for (unsigned i = 0; i < 3; ++i) {
    f[i].id = p::kMessages[9 + i].base_id;
    f[i].dlc = 8;
    f[i].data = payloads.data[i];
  }
  return f;
}

TEST(LogAssemblerTest, PairsTheThreeFramesOfACycleWithTheirScaling) {
  LogAssembler a;
  for (const auto& f : log_frames(7, {0.3, -0.25, 1.1}, {-0.7, 0.05, -1.234}))
    EXPECT_TRUE(a.feed(f));
  delta::can::Frame other;
  other.id = 0x181;
  other.dlc = 8;
  EXPECT_FALSE(a.feed(other));
  // The first cycle is judged once a later one (or the end) shows that no
  // arm-encoder frames (LOG_D, LOG_E) follow it.
  EXPECT_TRUE(a.take_complete().empty());
  a.finish();
  EXPECT_FALSE(a.arm_encoders());
  const auto s = a.take_complete();
  ASSERT_EQ(s.size(), 1u);
  EXPECT_EQ(s[0].seq, 7u);
  EXPECT_NEAR(s[0].q_rad[1], -0.25, 1e-6);
  EXPECT_NEAR(s[0].q_rad[2], 1.1, 1e-6);
  EXPECT_NEAR(s[0].tau_Nm[2], -1.234, 1e-5);
  EXPECT_EQ(a.lost_samples(), 0u);
}

// LOG_D and LOG_E of one cycle, as the controller sends them with
// arm_encoders = true.
std::array<delta::can::Frame, 2> arm_frames(std::uint32_t seq, const std::array<double, 3>& qa) {
  std::array<std::int32_t, 3> qa_raw{};
  for (unsigned j = 0; j < 3; ++j)
    qa_raw[j] = static_cast<std::int32_t>(std::llround(qa[j] * 1048576.0));
  const p::ArmLogPayloads payloads = p::pack_arm_log(seq, false, qa_raw);
  std::array<delta::can::Frame, 2> f{};
  f[0].id = p::kLogD.base_id;
  f[0].dlc = p::kLogD.dlc;
  f[0].data = payloads.data[0];
  f[1].id = p::kLogE.base_id;
  f[1].dlc = p::kLogE.dlc;
  f[1].data = payloads.data[1];
  return f;
}

// With arm-side encoders every cycle has five frames; a cycle that lacks
// LOG_D or LOG_E is lost like one that lacks LOG_A, never written without
// its arm angles.
TEST(LogAssemblerTest, ArmEncoderFramesGiveTheArmAnglesAndAreThenNeededInEveryCycle) {
  LogAssembler a;
  for (std::uint32_t k = 10; k < 60; ++k) {
    const double x = 0.01 * k;
    for (const auto& f : log_frames(k, {x, -x, 0.5}, {})) a.feed(f);
    const auto arm = arm_frames(k, {x + 0.001, -x - 0.002, 0.5 + 0.003});
    if (k != 30) {
      EXPECT_TRUE(a.feed(arm[0]));
    }
    if (k != 40) {
      EXPECT_TRUE(a.feed(arm[1]));
    }
  }
  a.finish();
  EXPECT_TRUE(a.arm_encoders());
  const auto s = a.take_complete();
  ASSERT_EQ(s.size(), 48u);
  using Run = std::pair<std::uint64_t, std::uint64_t>;
  EXPECT_EQ(a.gaps(), (std::vector<Run>{{30, 1}, {40, 1}}));
  for (const LogSample& x : s) {
    const double q = 0.01 * static_cast<double>(x.seq);
    ASSERT_NEAR(x.qa_rad[0], q + 0.001, 1e-6) << x.seq;
    ASSERT_NEAR(x.qa_rad[1], -q - 0.002, 1e-6) << x.seq;
    ASSERT_NEAR(x.qa_rad[2], 0.503, 1e-6) << x.seq;
  }
  // A frame of another length under LOG_E's ID is none of the log's.
  delta::can::Frame odd = arm_frames(61, {})[1];
  odd.dlc = 8;
  EXPECT_FALSE(a.feed(odd));
}

// A recording whose first cycle came without them is a log without arm
// angles, whatever comes later.
TEST(LogAssemblerTest, ArmFramesAfterACycleWithoutThemAreNotTheLogs) {
  LogAssembler a;
  for (std::uint32_t k = 0; k < 20; ++k) {
    for (const auto& f : log_frames(k, {}, {})) a.feed(f);
    if (k >= 5) {
      for (const auto& f : arm_frames(k, {1.0, 1.0, 1.0})) EXPECT_TRUE(a.feed(f));
    }
  }
  a.finish();
  EXPECT_FALSE(a.arm_encoders());
  EXPECT_EQ(a.take_complete().size(), 20u);
  EXPECT_EQ(a.lost_samples(), 0u);
  // Counted, and said.
  EXPECT_EQ(a.arm_frames_left_out(), 30u);
  RecordSummary s;
  s.arm_frames_left_out = a.arm_frames_left_out();
  std::ostringstream err;
  report_left_out(err, "host_id record", s);
  EXPECT_EQ(err.str(),
            "host_id record: 30 LOG_D/LOG_E frames (the arm-side encoders) came after cycles "
            "without them and are not in the log, which has no qa1..qa3: start the recording "
            "once the controller logs them\n");
  EXPECT_EQ(json_summary(s)["arm_frames_left_out"], 30);
}

// A recording without a complete sample says which frames never came: a
// recorder whose filter lets LOG_D through but not LOG_E (as
// host_id record's did before it asked for both) has the arm encoders'
// first frame and never a whole cycle.
TEST(LogAssemblerTest, WhyNoSampleWasCompleteNamesTheFramesThatNeverCame) {
  LogAssembler none;
  EXPECT_EQ(missing_log_frames(none),
            "no controller log frame came: LOG_A 0x190, LOG_B 0x290, LOG_C 0x390");
  LogAssembler arm;
  for (std::uint32_t k = 0; k < 10; ++k) {
    for (const auto& f : log_frames(k, {}, {})) arm.feed(f);
    arm.feed(arm_frames(k, {})[0]);
  }
  arm.finish();
  EXPECT_TRUE(arm.take_complete().empty());
  EXPECT_EQ(missing_log_frames(arm),
            "these log frames never came: LOG_E 0x2D0 (the arm encoders' frames did: is the "
            "recorder filtering them?)");
  LogAssembler no_c;
  for (std::uint32_t k = 0; k < 10; ++k) {
    const auto f = log_frames(k, {}, {});
    no_c.feed(f[0]);
    no_c.feed(f[1]);
  }
  no_c.finish();
  EXPECT_EQ(missing_log_frames(no_c), "these log frames never came: LOG_C 0x390");
}

TEST(LogAssemblerTest, TheFifteenBitCounterWrapsWithoutAGap) {
  LogAssembler a;
  // Twice round the 32768 wrap; the frames carry seq modulo 32768.
  for (std::uint32_t k = 32760; k < 65546; ++k) {
    for (const auto& f : log_frames(k, {}, {})) a.feed(f);
  }
  a.finish();
  const auto s = a.take_complete();
  ASSERT_EQ(s.size(), 65546u - 32760u);
  for (std::size_t i = 0; i < s.size(); ++i) ASSERT_EQ(s[i].seq, 32760u + i);
  EXPECT_EQ(a.lost_samples(), 0u);
}

TEST(LogAssemblerTest, AdjacentLossesAreOneRunAndAnIncompleteCycleBeforeTheLastIsLost) {
  LogAssembler a;
  for (std::uint32_t k = 0; k < 100; ++k) {
    const auto f = log_frames(k, {}, {});
    if (k == 30 || k == 31) continue;  // two whole cycles lost
    for (unsigned i = 0; i < 3; ++i) {
      if ((k == 32 || k == 98) && i == 2) continue;  // then an incomplete one, and another
      a.feed(f[i]);
    }
  }
  a.finish();
  EXPECT_EQ(a.take_complete().size(), 96u);
  EXPECT_EQ(a.lost_samples(), 4u);
  using Run = std::pair<std::uint64_t, std::uint64_t>;
  EXPECT_EQ(a.gaps(), (std::vector<Run>{{30, 3}, {98, 1}}));
  EXPECT_EQ(a.cut_off().second, 0u);
}

// The controller stopped (or was killed) inside a cycle's frames: the cycles
// after the last complete one are cut off, not lost; the log has no gap.
TEST(LogAssemblerTest, CyclesTheRecordingEndedInsideAreCutOffNotLost) {
  LogAssembler a;
  for (std::uint32_t k = 0; k < 100; ++k) {
    const auto f = log_frames(k, {}, {});
    if (k == 97) continue;
    for (unsigned i = 0; i < 3; ++i) {
      if (k >= 98 && i > 0) continue;  // 97 never came; only LOG_A of 98 and 99
      a.feed(f[i]);
    }
  }
  a.finish();
  EXPECT_EQ(a.take_complete().size(), 97u);
  EXPECT_EQ(a.lost_samples(), 0u);
  EXPECT_TRUE(a.gaps().empty());
  using Run = std::pair<std::uint64_t, std::uint64_t>;
  EXPECT_EQ(a.cut_off(), (Run{97, 3}));
  // Ended between cycles: nothing cut off.
  LogAssembler whole;
  for (std::uint32_t k = 0; k < 3; ++k)
    for (const auto& f : log_frames(k, {}, {})) whole.feed(f);
  whole.finish();
  EXPECT_EQ(whole.cut_off(), (Run{0, 0}));
  EXPECT_EQ(whole.take_complete().size(), 3u);
}

TEST(LogAssemblerTest, ARecordMarkedStaleIsLeftOutAndReportedButNotLost) {
  LogAssembler a;
  for (std::uint32_t k = 0; k < 100; ++k) {
    const bool stale = k == 40 || k == 41 || k == 77;
    for (const auto& f : log_frames(k, {0.001 * k, 0, 0}, {}, stale)) a.feed(f);
  }
  a.finish();
  const auto s = a.take_complete();
  ASSERT_EQ(s.size(), 97u);
  EXPECT_EQ(s[39].seq, 39u);
  EXPECT_EQ(s[40].seq, 42u);  // the log keeps the gap in seq
  EXPECT_NEAR(s[40].q_rad[0], 0.042, 1e-6);
  EXPECT_EQ(s[75].seq, 78u);
  EXPECT_EQ(a.lost_samples(), 0u);
  EXPECT_TRUE(a.gaps().empty());
  EXPECT_EQ(a.stale_samples(), 3u);
  using Run = std::pair<std::uint64_t, std::uint64_t>;
  EXPECT_EQ(a.stale_runs(), (std::vector<Run>{{40, 2}, {77, 1}}));
}

TEST(LogAssemblerTest, StaleAndLostAreReportedEachByName) {
  RecordSummary s;
  s.gaps = {{10, 3}};
  s.stale_runs = {{40, 2}};
  s.started_inside = {5, 1};
  s.cut_off = {71, 1};
  std::ostringstream err;
  report_left_out(err, "host_id record", s);
  EXPECT_EQ(err.str(),
            "host_id record: lost 3 sample(s) from seq 10 (log frames missing)\n"
            "host_id record: left out 2 sample(s) from seq 40: the controller marked them stale "
            "(a drive's feedback missed the cycle)\n"
            "host_id record: the recording began inside 1 sample(s) from seq 5 (their first log "
            "frames came before it listened): not written, no gap in the log\n"
            "host_id record: the recording ended inside 1 sample(s) from seq 71 (their log "
            "frames were incomplete): not written, no gap in the log\n");
}

TEST(LogAssemblerTest, PartsArrivingOutOfOrderStillPair) {
  LogAssembler a;
  const auto f1 = log_frames(1, {0.1, 0.1, 0.1}, {});
  const auto f2 = log_frames(2, {0.2, 0.2, 0.2}, {});
  a.feed(f1[0]);
  a.feed(f2[0]);
  a.feed(f2[1]);
  a.feed(f1[2]);
  a.feed(f1[1]);
  a.feed(f2[2]);
  const auto s = a.take_complete();
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].seq, 1u);
  EXPECT_NEAR(s[1].q_rad[0], 0.2, 1e-6);
}

TEST(LogAssemblerTest, AMissingFrameOrCycleIsALostSampleNeverBridged) {
  LogAssembler a;
  for (std::uint16_t k = 0; k < 200; ++k) {
    const auto f = log_frames(k, {}, {});
    if (k == 50) continue;  // a whole cycle lost
    for (int i = 0; i < 3; ++i) {
      if (k == 120 && i == 1) continue;  // one frame lost
      a.feed(f[static_cast<std::size_t>(i)]);
    }
  }
  a.finish();
  const auto s = a.take_complete();
  EXPECT_EQ(s.size(), 198u);
  EXPECT_EQ(a.lost_samples(), 2u);
  ASSERT_EQ(a.gaps().size(), 2u);
  EXPECT_EQ(a.gaps()[0], (std::pair<std::uint64_t, std::uint64_t>{50, 1}));
  EXPECT_EQ(a.gaps()[1], (std::pair<std::uint64_t, std::uint64_t>{120, 1}));
  for (std::size_t i = 1; i < s.size(); ++i) EXPECT_GT(s[i].seq, s[i - 1].seq);
}

// The recording began inside a cycle's frames (LOG_A went out before it
// listened), and a frame of the next was dropped: both come before the
// first complete cycle, where the log starts, so they are not lost. A cycle
// dropped after it is.
TEST(LogAssemblerTest, CyclesBeforeTheFirstCompleteOneAreStartedInsideNotLost) {
  LogAssembler a;
  for (std::uint32_t k = 40; k < 100; ++k) {
    const auto f = log_frames(k, {}, {});
    for (unsigned i = 0; i < 3; ++i) {
      if ((k == 40 && i == 0) || (k == 41 && i == 1) || (k == 70 && i == 2)) continue;
      a.feed(f[i]);
    }
  }
  a.finish();
  const auto s = a.take_complete();
  ASSERT_EQ(s.size(), 57u);
  EXPECT_EQ(s.front().seq, 42u);
  using Run = std::pair<std::uint64_t, std::uint64_t>;
  EXPECT_EQ(a.started_inside(), (Run{40, 2}));
  EXPECT_EQ(a.lost_samples(), 1u);
  EXPECT_EQ(a.gaps(), (std::vector<Run>{{70, 1}}));
  EXPECT_EQ(a.cut_off(), (Run{0, 0}));
}

TEST(LogAssemblerTest, AnIncompleteOnlyCycleIsCutOffAtTheEnd) {
  LogAssembler a;
  const auto f = log_frames(3, {}, {});
  a.feed(f[0]);
  a.feed(f[1]);
  EXPECT_TRUE(a.take_complete().empty());
  a.finish();
  EXPECT_EQ(a.lost_samples(), 0u);
  EXPECT_EQ(a.cut_off(), (std::pair<std::uint64_t, std::uint64_t>{3, 1}));
}

// A drive's TPDO1 with this current (per mille of the rated current).
delta::can::Frame tpdo1(std::uint8_t node, std::int16_t current_pm) {
  delta::can::Frame f;
  f.id = p::cob_id(p::kTpdo1, node);
  f.dlc = p::kTpdo1.dlc;
  p::pack(f.data, p::kTpdo1CurrentActual, current_pm);
  return f;
}

TEST(DriveCurrentTrackerTest, ARecordGetsTheCurrentsOfItsOwnCycleOrNone) {
  DriveCurrentTracker t;
  EXPECT_FALSE(t.any_seen());
  // Cycle 7: all three drives, then the log frames.
  for (std::uint8_t n = 1; n <= 3; ++n) t.feed(tpdo1(n, static_cast<std::int16_t>(-100 * n)));
  for (const auto& f : log_frames(7, {}, {})) t.feed(f);
  // Cycle 8: drive 2 is missing, so its old value must not be used.
  t.feed(tpdo1(1, 11));
  t.feed(tpdo1(3, 33));
  for (const auto& f : log_frames(8, {}, {})) t.feed(f);
  // Cycle 9: complete again.
  for (std::uint8_t n = 1; n <= 3; ++n) t.feed(tpdo1(n, static_cast<std::int16_t>(n)));
  for (const auto& f : log_frames(9, {}, {})) t.feed(f);
  EXPECT_TRUE(t.any_seen());
  const auto c7 = t.take(7);
  ASSERT_TRUE(c7.has_value());
  EXPECT_EQ((*c7)[0], -100);
  EXPECT_EQ((*c7)[1], -200);
  EXPECT_EQ((*c7)[2], -300);
  EXPECT_FALSE(t.take(8).has_value());
  const auto c9 = t.take(9);
  ASSERT_TRUE(c9.has_value());
  EXPECT_EQ((*c9)[2], 3);
  EXPECT_FALSE(t.take(9).has_value()) << "taken out";
}

// An EMCY frame as a node sends it: error code, error register, then
// manufacturer bytes (the controller's fault code at bytes 3-4).
delta::can::Frame emcy(std::uint8_t node, std::uint16_t code, std::uint8_t error_register,
                       std::uint16_t fault_code = 0) {
  delta::can::Frame f;
  f.id = p::cob_id(p::kEmcy, node);
  f.dlc = 8;
  p::pack(f.data, p::kEmcyErrorCode, code);
  p::pack(f.data, p::kEmcyErrorRegister, error_register);
  if (node == p::kControllerNode) p::pack(f.data, p::kControllerEmcyFaultCode, fault_code);
  return f;
}

TEST(EmergencyWatchTest, KeepsDrivesAndControllersEmcysWithTheirPlaceInTheLog) {
  EmergencyWatch w;
  delta::can::Frame sync;
  sync.id = p::cob_id(p::kSync, 0);  // 0x080: the EMCY function code, node 0
  w.feed(sync, std::nullopt);
  w.feed(log_frames(1, {}, {})[0], std::nullopt);
  w.feed(emcy(2, 0x8130, 0x11), std::nullopt);
  w.feed(emcy(3, 0x2310, 0x02), 6.642);
  w.feed(emcy(p::kControllerNode, 0xFF02, 0x01, 2), 6.644);
  w.feed(emcy(p::kControllerNode, 0x0000, 0x00), 9.0);
  ASSERT_EQ(w.seen().size(), 4u);
  EXPECT_EQ(describe_emergency(w.seen()[0]),
            "node 2 sent EMCY 0x8130 (life guard or heartbeat error), error register 0x11, "
            "before the log's first sample");
  EXPECT_EQ(describe_emergency(w.seen()[1]),
            "node 3 sent EMCY 0x2310 (continuous over-current), error register 0x02, after the "
            "log's sample at t = 6.642 s");
  EXPECT_EQ(describe_emergency(w.seen()[2]),
            "the controller (node 16) sent EMCY 0xFF02: fault 2 (drive fault), error register "
            "0x01, after the log's sample at t = 6.644 s");
  EXPECT_EQ(describe_emergency(w.seen()[3]),
            "the controller (node 16) sent EMCY 0x0000 (error reset), error register 0x00, after "
            "the log's sample at t = 9 s");
}

TEST(EmergencyWatchTest, AStormIsCountedBeyondWhatItKeeps) {
  EmergencyWatch w;
  for (int i = 0; i < 100; ++i) w.feed(emcy(1, 0x8210, 0x10), 0.5);
  EXPECT_EQ(w.seen().size(), EmergencyWatch::kKept);
  EXPECT_EQ(w.not_kept(), 100 - EmergencyWatch::kKept);
  RecordSummary s;
  s.emergencies = w.seen();
  s.emergencies_not_kept = w.not_kept();
  std::ostringstream err;
  report_emergencies(err, "host_id record", s);
  const std::string text = err.str();
  EXPECT_EQ(std::count(text.begin(), text.end(), '\n'), 17);
  EXPECT_NE(text.find("host_id record: node 1 sent EMCY 0x8210 (PDO not processed due to length "
                      "error)"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("host_id record: and 84 more EMCY frame(s)\n"), std::string::npos) << text;
}

// The controller's COLLISION frames (TPDO4 of node 16), one per joint:
// the first collision is kept whole, with its place in the log; frames of
// other IDs, lengths or joints are not its; a second collision's frames do
// not overwrite it.
delta::can::Frame collision_frame(unsigned joint, unsigned tripped, double residual_Nm,
                                  double threshold_Nm) {
  delta::can::Frame f;
  f.id = p::kCollision.base_id;
  f.dlc = 8;
  p::pack(f.data, p::kCollisionJoint, joint);
  p::pack(f.data, p::kCollisionTripped, tripped);
  p::pack(f.data, p::kCollisionResidual, std::llround(residual_Nm * 65536.0));
  p::pack(f.data, p::kCollisionThreshold, std::llround(threshold_Nm * 65536.0));
  return f;
}

TEST(CollisionWatchTest, KeepsTheControllersCollisionWithItsPlaceInTheLog) {
  CollisionWatch w;
  delta::can::Frame short_one = collision_frame(1, 1, 1.0, 1.0);
  short_one.dlc = 4;
  w.feed(short_one, 2.0);
  w.feed(collision_frame(4, 1, 1.0, 1.0), 2.0);
  EXPECT_FALSE(w.seen().has_value());
  w.feed(collision_frame(1, 2, 0.0625, 0.125), 3.004);
  w.feed(collision_frame(2, 2, -0.25, 0.1875), 3.004);
  ASSERT_TRUE(w.seen().has_value());
  EXPECT_EQ(w.seen()->joints_seen, 0x3);
  EXPECT_NE(describe_collision(*w.seen()).find("some of its frames were lost"), std::string::npos);
  w.feed(collision_frame(3, 2, 0.5, 0.75), 3.004);
  w.feed(collision_frame(1, 3, 9.0, 9.0), 5.0);
  const SeenCollision& c = *w.seen();
  EXPECT_EQ(c.joint, 2u);
  EXPECT_EQ(c.residual_Nm, (std::array<double, 3>{0.0625, -0.25, 0.5}));
  EXPECT_EQ(c.threshold_Nm, (std::array<double, 3>{0.125, 0.1875, 0.75}));
  EXPECT_EQ(describe_collision(c),
            "the controller detected a collision after the log's sample at t = 3.004 s: joint 2, "
            "residual 0.0625, -0.25, 0.5 N m against thresholds 0.125, 0.1875, 0.75 N m");
}

// A first collision whose frames were partly lost is not completed by a
// later one's.
TEST(CollisionWatchTest, ALaterCollisionDoesNotFillInTheFirstsLostFrames) {
  CollisionWatch w;
  w.feed(collision_frame(1, 1, 0.5, 0.25), 1.0);
  w.feed(collision_frame(2, 3, 9.0, 9.0), 7.5);
  w.feed(collision_frame(1, 3, 9.0, 9.0), 7.5);
  ASSERT_TRUE(w.seen().has_value());
  EXPECT_EQ(w.seen()->joints_seen, 0x1);
  EXPECT_EQ(w.seen()->residual_Nm, (std::array<double, 3>{0.5, 0.0, 0.0}));
}

// --json's summary (record, excite) carries every count the text reports,
// with the runs of lost and stale samples and the emergencies.
TEST(RecordSummaryTest, TheJsonSummaryCarriesEveryCount) {
  RecordSummary s;
  s.samples = 6000;
  s.frames = 18000;
  s.seconds = 12.5;
  s.lost = 3;
  s.gaps = {{100, 2}, {4000, 1}};
  s.stale = 1;
  s.stale_runs = {{200, 1}};
  s.currents = true;
  s.emergencies.push_back(SeenEmergency{2, 0x8130, 1, 0, 3.25});
  const nlohmann::json j = json_summary(s);
  EXPECT_EQ(j["samples"], 6000u);
  EXPECT_EQ(j["lost"], 3u);
  EXPECT_EQ(j["gaps"].size(), 2u);
  EXPECT_EQ(j["gaps"][1]["first_seq"], 4000u);
  EXPECT_EQ(j["stale_runs"][0]["count"], 1u);
  EXPECT_EQ(j["currents"], true);
  EXPECT_EQ(j["emergencies"][0]["code"], 0x8130);
  EXPECT_DOUBLE_EQ(j["emergencies"][0]["after_log_t_s"].get<double>(), 3.25);
  EXPECT_DOUBLE_EQ(j["seconds"].get<double>(), 12.5);
}

}  // namespace
}  // namespace host_id
