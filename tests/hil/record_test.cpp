// host_id record on a real vcan interface: frames sent as the controller
// sends them, recorded, and read back as delta-log/1.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <thread>

#include "delta/atomic_file.hpp"
#include "delta/can/protocol.hpp"
#include "delta/can/socketcan.hpp"
#include "delta/read_file.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/recorder.hpp"
#include "scratch_directory.hpp"
#include "vcan_interface.hpp"

namespace host_id {
namespace {

namespace p = delta::can::protocol;
const std::string kIface = hil::vcan_interface();

// One cycle's three log frames as the controller sends them (q and tau the
// same for all joints), leaving out part `skip_part`.
void send_cycle(delta::can::Socket& s, std::uint32_t seq, double q, double tau, int skip_part = -1,
                bool stale = false) {
  const auto q_raw = static_cast<std::int32_t>(std::llround(q * 1048576.0));
  const auto tau_raw = static_cast<std::int32_t>(std::llround(tau * 65536.0));
  const p::LogPayloads payloads =
      p::pack_log(seq, stale, {q_raw, q_raw, q_raw}, {tau_raw, tau_raw, tau_raw});
  for (unsigned i = 0; i < 3; ++i) {
    if (static_cast<int>(i) == skip_part) continue;
    delta::can::Frame f;
    f.id = p::kMessages[9 + i].base_id;
    f.dlc = 8;
    f.data = payloads.data[i];
    ASSERT_EQ(s.send(f), delta::can::SendResult::kOk);
  }
}

struct Recording {
  RecordSummary summary;
  std::string error;
};

// Runs record() in a thread and calls `send` once its socket is open.
Recording record_while(const RecordOptions& o, const std::function<void()>& send) {
  std::mutex m;
  std::condition_variable cv;
  bool ready = false;
  Recording r;
  std::thread t([&] {
    try {
      r.summary = record(o, [&] {
        std::lock_guard<std::mutex> lock(m);
        ready = true;
        cv.notify_one();
      });
    } catch (const std::exception& e) {
      r.error = e.what();
      std::lock_guard<std::mutex> lock(m);
      ready = true;
      cv.notify_one();
    }
  });
  {
    std::unique_lock<std::mutex> lock(m);
    cv.wait(lock, [&] { return ready; });
  }
  if (r.error.empty()) send();
  t.join();
  return r;
}

class RecordHilTest : public ::testing::Test {
 protected:
  const testsupport::ScratchDirectory scratch_{"record_hil"};
  const std::string dir_ = scratch_.path();
};

TEST_F(RecordHilTest, RecordsTheControllersLogFramesIntoADeltaLog) {
  RecordOptions o;
  o.iface = kIface;
  o.out_path = dir_ + "/run.csv";
  o.raw_path = dir_ + "/run.log";
  o.samples = 500;
  o.duration_s = 30;  // a bound in case frames never come
  o.sample_rate_hz = 500;
  delta::can::Socket tx = delta::can::Socket::open(kIface);
  const Recording r = record_while(o, [&] {
    for (int k = 0; k < 500; ++k) {
      send_cycle(tx, static_cast<std::uint32_t>(32600 + k), 0.001 * k - 0.2, -0.5 + 0.0005 * k);
    }
  });
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(r.summary.samples, 500u);
  EXPECT_EQ(r.summary.lost, 0u);
  EXPECT_EQ(r.summary.frames, 1500u);
  const DeltaLog log = read_delta_log(o.out_path);
  ASSERT_EQ(log.size(), 500u);
  EXPECT_TRUE(log.gaps.empty());
  EXPECT_EQ(log.metadata_value("can_interface").value_or(""), kIface);
  EXPECT_DOUBLE_EQ(*log.sample_rate_hz, 500.0);
  for (std::size_t k = 0; k < 500; ++k) {
    EXPECT_NEAR(log.t[k], static_cast<double>(k) / 500.0, 1e-12);  // through the 15-bit wrap
    EXPECT_NEAR(log.q[0][k], 0.001 * static_cast<double>(k) - 0.2, 1e-6);
    EXPECT_NEAR(log.tau[2][k], -0.5 + 0.0005 * static_cast<double>(k), 2e-5);
  }
  // The raw log is candump -L: one line per frame.
  const std::string raw = delta::read_whole_file(*o.raw_path);
  EXPECT_EQ(std::count(raw.begin(), raw.end(), '\n'), 1500);
  // "(seconds.micros) IFACE 190#<16 hex digits>"
  const std::string first = raw.substr(0, raw.find('\n'));
  const auto close = first.find(") ");
  ASSERT_NE(close, std::string::npos) << first;
  EXPECT_EQ(first[0], '(');
  const std::string stamp = first.substr(1, close - 1);
  ASSERT_EQ(stamp.find('.'), stamp.size() - 7) << first;  // six decimals
  const std::string prefix = kIface + " 190#";
  EXPECT_EQ(first.substr(close + 2, prefix.size()), prefix) << first;
  const std::string hex = first.substr(close + 2 + prefix.size());
  EXPECT_EQ(hex.size(), 16u) << first;
  EXPECT_EQ(hex.find_first_not_of("0123456789ABCDEF"), std::string::npos) << first;
}

// --idle counts from the first log frame: a controller that starts logging
// well after record is listening (a slow bring-up) is recorded whole.
TEST_F(RecordHilTest, IdleCountsFromTheFirstLogFrame) {
  RecordOptions o;
  o.iface = kIface;
  o.out_path = dir_ + "/late.csv";
  o.idle_s = 0.3;
  o.duration_s = 30;
  delta::can::Socket tx = delta::can::Socket::open(kIface);
  const auto t0 = std::chrono::steady_clock::now();
  const Recording r = record_while(o, [&] {
    // The controller's bring-up, longer than the idle time: the behaviour
    // under test, not a wait for anything.
    std::this_thread::sleep_for(std::chrono::milliseconds(1000));
    for (int k = 0; k < 100; ++k) send_cycle(tx, static_cast<std::uint32_t>(k), 0.1, 0.2);
  });
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(r.summary.samples, 100u);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(1300));
}

TEST_F(RecordHilTest, LostFramesAreReportedAndKeptAsGapsInSeq) {
  RecordOptions o;
  o.iface = kIface;
  o.out_path = dir_ + "/gappy.csv";
  o.idle_s = 0.5;  // the run ends when frames stop
  o.duration_s = 30;
  delta::can::Socket tx = delta::can::Socket::open(kIface);
  const Recording r = record_while(o, [&] {
    for (int k = 0; k < 301; ++k) {
      if (k >= 100 && k < 103) continue;  // three cycles lost
      // One frame lost; the first and the last cycle cut off.
      const int dropped = k == 200 ? 1 : (k == 0 ? 0 : (k == 300 ? 2 : -1));
      send_cycle(tx, static_cast<std::uint32_t>(k), 0.1, 0.2, dropped,
                 k == 250);  // and one record the controller marked stale
    }
  });
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(r.summary.samples, 294u);
  EXPECT_EQ(r.summary.lost, 4u);
  ASSERT_EQ(r.summary.gaps.size(), 2u);
  EXPECT_EQ(r.summary.gaps[0].first, 100u);
  EXPECT_EQ(r.summary.gaps[0].second, 3u);
  EXPECT_EQ(r.summary.stale, 1u);
  using Run = std::pair<std::uint64_t, std::uint64_t>;
  EXPECT_EQ(r.summary.stale_runs, (std::vector<Run>{{250, 1}}));
  // The recording began inside the first cycle and ended inside the last:
  // cut off, not lost, no gap.
  EXPECT_EQ(r.summary.cut_off, (Run{300, 1}));
  EXPECT_EQ(r.summary.started_inside, (Run{0, 1}));
  // Any reader sees the gaps: the seq column jumps there.
  const DeltaLog log = read_delta_log(o.out_path);
  ASSERT_EQ(log.size(), 294u);
  ASSERT_EQ(log.gaps.size(), 3u);
  // (The log's seq counts from its first row, the bus's seq 1.)
  EXPECT_EQ(log.gaps[0].what, "seq jumps from 98 to 102 (3 samples lost)");
  EXPECT_EQ(log.gaps[2].what, "seq jumps from 248 to 250 (1 samples lost)");
  EXPECT_EQ(log.metadata_value("stale_samples").value_or(""), "1");
}

// Stopped at --samples, the summary is of the log written: a cycle lost
// before the limit is counted; one lost or marked stale after it, read while
// the earlier gap held the samples back for the reordering window, is not.
TEST_F(RecordHilTest, StoppedAtTheSampleLimitOnlyTheLogsLossesCount) {
  RecordOptions o;
  o.iface = kIface;
  o.out_path = dir_ + "/limited.csv";
  o.samples = 100;
  o.duration_s = 30;  // a bound in case frames never come
  delta::can::Socket tx = delta::can::Socket::open(kIface);
  const Recording r = record_while(o, [&] {
    for (int k = 0; k < 300; ++k) {
      if (k == 50) continue;  // lost before the limit (the log's 100th sample is seq 100)
      send_cycle(tx, static_cast<std::uint32_t>(k), 0.1, 0.2, k == 105 ? 1 : -1, k == 104);
    }
  });
  ASSERT_EQ(r.error, "");
  EXPECT_EQ(r.summary.samples, 100u);
  using Run = std::pair<std::uint64_t, std::uint64_t>;
  EXPECT_EQ(r.summary.lost, 1u);
  EXPECT_EQ(r.summary.gaps, (std::vector<Run>{{50, 1}}));
  EXPECT_EQ(r.summary.stale, 0u);
  EXPECT_TRUE(r.summary.stale_runs.empty());
  EXPECT_EQ(r.summary.cut_off, (Run{0, 0}));
  const DeltaLog log = read_delta_log(o.out_path);
  ASSERT_EQ(log.size(), 100u);
  ASSERT_EQ(log.gaps.size(), 1u);
  EXPECT_EQ(log.gaps[0].what, "seq jumps from 49 to 51 (1 samples lost)");
  EXPECT_FALSE(log.metadata_value("stale_samples").has_value());
}

TEST_F(RecordHilTest, NothingArrivingWritesNothing) {
  RecordOptions o;
  o.iface = kIface;
  o.out_path = dir_ + "/empty.csv";
  o.duration_s = 0.3;
  const Recording r = record_while(o, [] {});
  EXPECT_NE(r.error.find("no complete log sample arrived on " + kIface), std::string::npos)
      << r.error;
  EXPECT_FALSE(std::filesystem::exists(o.out_path));
}

}  // namespace
}  // namespace host_id
