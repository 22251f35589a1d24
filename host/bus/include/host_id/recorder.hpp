// `host_id record`: the controller's log frames (LOG_A..E, docs/protocol.md)
// from a CAN bus into delta-log/1. Samples are paired by their 15-bit
// sequence counter, unwrapped to 64 bits; a cycle with a missing frame is a
// lost sample, reported and never bridged (the log keeps its seq column).
// A cycle the controller marked stale (a drive's feedback missed it) is left
// out the same way, and reported apart from the lost ones. Cycles still
// incomplete after the last complete one when the recording ends (the
// controller stopped or was killed inside a cycle's frames), or before the
// first complete one (the recording began inside a cycle's frames), are cut
// off: reported, not written, and no gap in the log.
#pragma once

#include <cstdint>
#include <functional>
#include <iosfwd>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "delta/can/socketcan.hpp"
#include "delta/geometry.hpp"
#include "host_id/delta_log.hpp"

namespace host_id {

struct LogSample {
  std::uint64_t seq{0};  // unwrapped
  std::array<double, 3> q_rad{};
  std::array<double, 3> tau_Nm{};
  std::array<double, 3> qa_rad{};  // the arm-side encoders, where the controller logs them
  bool stale{false};               // marked stale by the controller: never emitted as a sample
};

// Pairs LOG_A, LOG_B and LOG_C frames into samples, in order, with LOG_D
// and LOG_E (the arm-side encoders) where the controller sends them: a
// recording takes them when they come with its first cycle, and then
// needs them in every cycle.
class LogAssembler {
 public:
  // Feeds one frame; other IDs are ignored. Returns true if it was a log frame.
  bool feed(const delta::can::Frame& f);
  // Samples completed so far, in sequence order (taken out).
  std::vector<LogSample> take_complete();
  // Flushes what is pending at the end: incomplete cycles between complete
  // ones count as lost, those after the last as cut off (cut_off()), those
  // before the first as started inside (started_inside()).
  void finish();
  std::uint64_t lost_samples() const { return lost_; }
  // (first lost seq, count) for each run of lost samples.
  const std::vector<std::pair<std::uint64_t, std::uint64_t>>& gaps() const { return gaps_; }
  // Complete cycles the controller marked stale, left out; (first seq, count).
  std::uint64_t stale_samples() const { return stale_; }
  const std::vector<std::pair<std::uint64_t, std::uint64_t>>& stale_runs() const {
    return stale_runs_;
  }
  // The cycles after the last complete one that finish() found incomplete:
  // (first seq, count); count 0 when the recording ended between cycles.
  std::pair<std::uint64_t, std::uint64_t> cut_off() const { return cut_off_; }
  // The same at the start: incomplete cycles before the first complete one
  // (their first frames came before the recording listened).
  std::pair<std::uint64_t, std::uint64_t> started_inside() const { return started_inside_; }
  // Whether the samples carry the arm-side encoders (qa_rad).
  bool arm_encoders() const { return arm_.value_or(false); }
  // Bit i: a frame of part i (LOG_A .. LOG_E) came.
  unsigned parts_seen() const { return parts_seen_; }
  // LOG_D and LOG_E frames after a first cycle without them: left out.
  std::uint64_t arm_frames_left_out() const { return arm_frames_left_out_; }

 private:
  struct Pending {
    std::uint64_t seq{0};
    std::uint8_t parts{0};  // bit 0: A, 1: B, 2: C, 3: D, 4: E
    LogSample sample;
  };
  std::uint64_t unwrap(std::uint32_t seq15);
  void emit_up_to(std::uint64_t seq);
  void give_up(std::uint64_t first_seq, std::uint64_t count);

  std::vector<Pending> pending_;
  std::vector<LogSample> complete_;
  std::optional<std::uint64_t> last_seq_;      // the highest unwrapped seq seen
  std::optional<std::uint64_t> next_to_emit_;  // the next seq owed to the output
  std::uint64_t lost_{0};
  std::vector<std::pair<std::uint64_t, std::uint64_t>> gaps_;
  std::uint64_t stale_{0};
  std::vector<std::pair<std::uint64_t, std::uint64_t>> stale_runs_;
  std::pair<std::uint64_t, std::uint64_t> cut_off_{0, 0};
  std::pair<std::uint64_t, std::uint64_t> started_inside_{0, 0};
  bool emitted_any_{false};  // a complete cycle (sample or stale) was emitted
  // Whether cycles have LOG_D and LOG_E: decided by the first cycle whose
  // LOG_A..C came, once a later cycle's frame shows that it is over.
  std::optional<bool> arm_;
  unsigned parts_seen_{0};
  std::uint64_t arm_frames_left_out_{0};
  std::uint8_t whole() const { return arm_encoders() ? 0x1F : 0x07; }
  bool decided_whole(const Pending& x);
};

// Which of the log frames a recording needs never came, by name and COB-ID
// (LOG_D and LOG_E where the arm encoders' frames came): why no sample
// was complete.
std::string missing_log_frames(const LogAssembler& a);

// The drives' motor currents (TPDO1 of nodes 1..3, per mille of the rated
// current) for each log record: a record gets the currents that all three
// drives sent after the previous record's LOG_A frame (the SYNC of its own
// cycle); when one is missing, that record has none.
class DriveCurrentTracker {
 public:
  // Feeds one frame; other IDs are ignored.
  void feed(const delta::can::Frame& f);
  // The currents (per mille) that came with the record of this (unwrapped)
  // seq, taken out; nullopt if not all three came.
  std::optional<std::array<std::int16_t, 3>> take(std::uint64_t seq);
  bool any_seen() const { return any_seen_; }

 private:
  std::array<std::int16_t, 3> current_pm_{};
  std::uint8_t fresh_{0};  // bit per drive since the last LOG_A
  bool any_seen_{false};
  std::vector<std::pair<std::uint16_t, std::array<std::int16_t, 3>>> by_seq_;
};

// An emergency (EMCY) frame seen while recording, a drive's or the
// controller's, and where in the log it came.
struct SeenEmergency {
  std::uint8_t node{0};
  std::uint16_t code{0};
  std::uint8_t error_register{0};
  std::uint16_t fault_code{0};  // the controller's (node 16) fault; 0 for the drives
  // The log time (its t column) of the latest complete sample when it came;
  // none before the first.
  std::optional<double> after_log_t_s;
};

// Keeps the EMCY frames (COB-ID 0x081..0x0FF) of a recording, the first
// kKept of them (and counts the rest); other IDs are ignored.
class EmergencyWatch {
 public:
  static constexpr std::size_t kKept = 16;
  void feed(const delta::can::Frame& f, std::optional<double> log_t_s);
  const std::vector<SeenEmergency>& seen() const { return seen_; }
  std::uint64_t not_kept() const { return not_kept_; }

 private:
  std::vector<SeenEmergency> seen_;
  std::uint64_t not_kept_{0};
};

// A collision the controller detected (its COLLISION frames, TPDO4 of node
// 16: one per joint), and where in the log it came.
struct SeenCollision {
  unsigned joint{0};  // 1-3: the joint over its threshold
  std::array<double, 3> residual_Nm{}, threshold_Nm{};
  std::uint8_t joints_seen{0};  // bit j: joint j+1's frame came (0x7: whole)
  std::optional<double> after_log_t_s;
};

// Keeps the first collision of a recording (a run ends at one).
class CollisionWatch {
 public:
  void feed(const delta::can::Frame& f, std::optional<double> log_t_s);
  const std::optional<SeenCollision>& seen() const { return seen_; }

 private:
  std::optional<SeenCollision> seen_;
};

// "the controller detected a collision after the log's sample at t = 3.004
// s: joint 1, residual 0.21, -0.15, -0.13 N m against 0.19, 0.16, 0.15 N m".
std::string describe_collision(const SeenCollision& c);

// "node 2 sent EMCY 0x2310 (continuous over-current), error register 0x02,
// after the log's sample at t = 6.642 s"; the controller's names its fault.
std::string describe_emergency(const SeenEmergency& e);

struct RecordOptions {
  std::string iface;
  std::string out_path;
  std::optional<std::string> raw_path;  // candump -L format
  double duration_s{0};                 // 0: no limit
  std::uint64_t samples{0};             // 0: no limit
  double idle_s{0};                     // stop after this long without log frames; 0: never
  double sample_rate_hz{500};
  delta::Geometry geometry{delta::kDefaultGeometry};
  double rated_current_A{2.0};  // the drives' 0x6075, to turn per mille into A
  // Asked about every 50 ms with the controller's records accounted for so
  // far (samples, and stale records left out); false ends the recording
  // (another thread's decision: it must be thread-safe).
  std::function<bool(std::uint64_t records)> keep_going;
};

struct RecordSummary {
  std::uint64_t samples{0};
  std::uint64_t lost{0};
  std::vector<std::pair<std::uint64_t, std::uint64_t>> gaps;
  std::uint64_t stale{0};  // cycles the controller marked stale, left out (not lost)
  std::vector<std::pair<std::uint64_t, std::uint64_t>> stale_runs;
  // Cycles the recording ended inside (first seq, count): not written, not a
  // gap; 0 when it stopped at --samples. And those it began inside.
  std::pair<std::uint64_t, std::uint64_t> cut_off{0, 0};
  std::pair<std::uint64_t, std::uint64_t> started_inside{0, 0};
  std::uint64_t frames{0};
  std::uint32_t socket_drops{0};  // frames the kernel dropped for this reader
  bool currents{false};           // the log has i1..i3 (every sample had its drives' currents)
  bool arm_encoders{false};       // the log has qa1..qa3 (the controller sent LOG_D and LOG_E)
  // LOG_D and LOG_E frames that came after the first cycle without them:
  // not in the log.
  std::uint64_t arm_frames_left_out{0};
  std::uint64_t samples_without_currents{0};  // when drive PDOs were seen but some missed
  std::vector<SeenEmergency> emergencies;     // in the order they came
  std::uint64_t emergencies_not_kept{0};
  std::optional<SeenCollision> collision;  // the controller's, where it detected one
  double seconds{0};
};

// One line per run of lost samples, per run of stale ones left out and for
// the cycles cut off at the end, each starting with `who` ("host_id record").
void report_left_out(std::ostream& err, const std::string& who, const RecordSummary& s);
// A recording's files: the log, and the candump text where raw_path is
// given, both or (interrupted before) neither.
void write_recording(const std::string& log_path, const DeltaLog& log, const std::string& raw_path,
                     std::string_view raw);

// The summary as JSON, for --json (record, excite): samples, frames,
// seconds, lost and stale (with their runs of seq), cut-off cycles, drops,
// currents, emergencies.
nlohmann::json json_summary(const RecordSummary& s);

// One line per emergency seen (drives and controller), each starting with
// `who`; nothing when none came.
void report_emergencies(std::ostream& err, const std::string& who, const RecordSummary& s);

// Records until a limit is reached. `ready` is called once the socket is
// open (tests start sending then). Writes out_path (and raw_path) atomically.
RecordSummary record(const RecordOptions& o, const std::function<void()>& ready = {});

// The same, without writing: the log, the summary and the candump text
// (with raw_path). Throws delta::InputError when no complete sample arrived.
struct Recording {
  DeltaLog log;
  RecordSummary summary;
  std::string raw;
};
Recording capture(const RecordOptions& o, const std::function<void()>& ready = {});

}  // namespace host_id
