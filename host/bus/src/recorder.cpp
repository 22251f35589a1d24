// The recorder's socket session: frames read from the bus until a limit,
// assembled into the log, and the recording's files written.
#include "host_id/recorder.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <optional>
#include <ostream>
#include <thread>

#include "delta/atomic_file.hpp"
#include "delta/can/protocol.hpp"
#include "delta/input_error.hpp"

namespace host_id {

namespace p = delta::can::protocol;

using p::kLogA;
using p::kLogB;
using p::kLogC;

void write_recording(const std::string& log_path, const DeltaLog& log, const std::string& raw_path,
                     std::string_view raw) {
  delta::AtomicFileWriter log_file(log_path);
  write_delta_log(log_file, log);
  std::optional<delta::AtomicFileWriter> raw_file;
  if (!raw_path.empty()) {
    raw_file.emplace(raw_path);
    raw_file->write(raw);
  }
  delta::commit_together({&log_file, raw_file ? &*raw_file : nullptr});
}

RecordSummary record(const RecordOptions& o, const std::function<void()>& ready) {
  Recording r = capture(o, ready);
  write_recording(o.out_path, r.log, o.raw_path.value_or(""), r.raw);
  return r.summary;
}

namespace {

delta::can::Socket open_socket(const RecordOptions& o) {
  try {
    // With --raw, every frame of the session (a candump of it); else only
    // the log frames, the drives' currents and the emergencies.
    std::vector<delta::can::Filter> filters;
    if (!o.raw_path) {
      filters = {{kLogA.base_id, p::kStandardIdMask, false},
                 {kLogB.base_id, p::kStandardIdMask, false},
                 {kLogC.base_id, p::kStandardIdMask, false},
                 {p::kLogD.base_id, p::kStandardIdMask, false},
                 {p::kLogE.base_id, p::kStandardIdMask, false},
                 {p::kTpdo1.base_id, p::kFunctionCodeMask, false},
                 {p::kEmcy.base_id, p::kFunctionCodeMask, false},
                 {p::kCollision.base_id, p::kStandardIdMask, false}};
    }
    return delta::can::Socket::open(o.iface, filters,
                                    8 << 20);  // 8 MB: about 10 000 frames of burst
  } catch (const delta::can::CanError& e) {
    throw delta::InputError(std::string("record: ") + e.what());
  }
}

// One frame as a candump -L line: 3 hex digits for a standard ID, 8 for an
// extended or error frame (with its flag bit), R for a remote request.
void append_candump_line(const delta::can::Received& r, const std::string& iface,
                         std::string& raw) {
  char buf[96];
  const auto ns = r.kernel_time.count();
  const delta::can::Frame& f = r.frame;
  const std::uint32_t id =
      f.error_frame ? (0x20000000u | f.id) : (f.extended ? (0x80000000u | f.id) : f.id);
  std::snprintf(buf, sizeof buf,
                (f.error_frame || f.extended) ? "(%lld.%06lld) %s %08X#" : "(%lld.%06lld) %s %03X#",
                static_cast<long long>(ns / 1000000000),
                static_cast<long long>((ns % 1000000000) / 1000), iface.c_str(),
                f.extended ? (id & 0x1FFFFFFFu) : id);
  raw += buf;
  if (f.remote) raw += 'R';
  for (unsigned i = 0; !f.remote && i < f.dlc; ++i) {
    std::snprintf(buf, sizeof buf, "%02X", f.data[i]);
    raw += buf;
  }
  raw += '\n';
}

// Keeps the runs (first seq, count) that lie before seq `end`, clipped to
// it; returns how many seqs they hold.
std::uint64_t keep_runs_before(std::vector<std::pair<std::uint64_t, std::uint64_t>>& runs,
                               std::uint64_t end) {
  std::erase_if(runs, [end](const auto& run) { return run.first >= end; });
  std::uint64_t total = 0;
  for (auto& [first, count] : runs) {
    count = std::min(count, end - first);
    total += count;
  }
  return total;
}

// How long the recorder lets frames gather once the socket has one, before
// it reads them all: a control cycle's frames come in two or three bursts,
// and waking for each took a fifth of a CPU in the lock-step VM, which the
// emulator and the controller needed (docs/hil.md). The kernel stamps each
// frame as it arrives and the socket holds about 10 000 frames (a 1 Mbit/s
// bus carries at most about 200 in this time), so nothing depends on reading
// sooner.
constexpr auto kGatherFrames = std::chrono::milliseconds(10);

// The frames of one recording session, put together into samples.
class Session {
 public:
  explicit Session(const RecordOptions& o) : o_(o), t0_(std::chrono::steady_clock::now()) {}

  // Reads until a limit is reached or keep_going says no.
  void run(delta::can::Socket& sock) {
    while (!done()) {
      if (!sock.wait_readable(std::chrono::milliseconds(50))) continue;
      std::this_thread::sleep_for(kGatherFrames);
      while (auto r = sock.receive()) {
        take(*r);
        if (o_.samples > 0 && samples_.size() >= o_.samples) break;
      }
    }
    assembler_.finish();
    collect();
    limit_reached_ = o_.samples > 0 && samples_.size() >= o_.samples;
    if (o_.samples > 0 && samples_.size() > o_.samples) {
      samples_.resize(o_.samples);
      sample_currents_.resize(o_.samples);
    }
  }

  RecordSummary summary() const {
    RecordSummary s = summary_;
    s.seconds = elapsed();
    s.samples = samples_.size();
    s.lost = assembler_.lost_samples();  // dropped frames show up as incomplete cycles
    s.gaps = assembler_.gaps();
    s.stale = assembler_.stale_samples();
    s.stale_runs = assembler_.stale_runs();
    // Stopped at --samples, what came after the limit is not the log's:
    // neither the cycles cut off nor those lost or stale past its last sample
    // (read while an earlier gap held the samples back).
    if (!limit_reached_) {
      s.cut_off = assembler_.cut_off();
    } else if (!samples_.empty()) {
      s.lost = keep_runs_before(s.gaps, samples_.back().seq);
      s.stale = keep_runs_before(s.stale_runs, samples_.back().seq);
    }
    s.started_inside = assembler_.started_inside();
    s.emergencies = emergencies_.seen();
    s.emergencies_not_kept = emergencies_.not_kept();
    s.collision = collisions_.seen();
    s.arm_frames_left_out = assembler_.arm_frames_left_out();
    return s;
  }
  const std::vector<LogSample>& samples() const { return samples_; }
  const std::vector<std::optional<std::array<std::int16_t, 3>>>& sample_currents() const {
    return sample_currents_;
  }
  bool currents_seen() const { return currents_.any_seen(); }
  bool arm_encoders() const { return assembler_.arm_encoders(); }
  const LogAssembler& assembler() const { return assembler_; }
  std::string& raw() { return raw_; }

 private:
  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  }
  bool done() const {
    if (o_.keep_going && !o_.keep_going(samples_.size() + assembler_.stale_samples())) return true;
    if (o_.duration_s > 0 && elapsed() >= o_.duration_s) return true;
    if (o_.samples > 0 && samples_.size() >= o_.samples) return true;
    // --idle counts from the latest log frame, and only once one came: a
    // controller may take a while to bring its drives up before it logs.
    return o_.idle_s > 0 && last_log_frame_ &&
           std::chrono::duration<double>(std::chrono::steady_clock::now() - *last_log_frame_)
                   .count() >= o_.idle_s;
  }
  void take(const delta::can::Received& r) {
    ++summary_.frames;
    summary_.socket_drops = r.socket_drops;
    if (o_.raw_path) append_candump_line(r, o_.iface, raw_);
    if (!r.error) currents_.feed(r.frame);
    if (!r.error) emergencies_.feed(r.frame, log_time_s());
    if (!r.error) collisions_.feed(r.frame, log_time_s());
    if (!r.error && assembler_.feed(r.frame)) last_log_frame_ = std::chrono::steady_clock::now();
    collect();
  }
  // The t of the log's latest complete sample (the log starts at its first).
  std::optional<double> log_time_s() const {
    if (samples_.empty()) return std::nullopt;
    return static_cast<double>(samples_.back().seq - samples_.front().seq) / o_.sample_rate_hz;
  }
  void collect() {
    for (auto& s : assembler_.take_complete()) {
      samples_.push_back(s);
      sample_currents_.push_back(currents_.take(s.seq));
    }
  }

  const RecordOptions& o_;
  std::chrono::steady_clock::time_point t0_;
  std::optional<std::chrono::steady_clock::time_point> last_log_frame_;
  LogAssembler assembler_;
  DriveCurrentTracker currents_;
  EmergencyWatch emergencies_;
  CollisionWatch collisions_;
  std::vector<LogSample> samples_;
  std::vector<std::optional<std::array<std::int16_t, 3>>> sample_currents_;
  std::string raw_;
  RecordSummary summary_;
  bool limit_reached_{false};
};

// A collision the controller detected, in the log's metadata: where it
// came in the log (collision_t_s: left out where it came before the first
// sample), the joint over its threshold, and every joint's residual and
// threshold (N m).
void add_collision_metadata(const SeenCollision& c, DeltaLog& log) {
  const auto three = [](const std::array<double, 3>& v) {
    char buf[96];
    std::snprintf(buf, sizeof buf, "%.6g,%.6g,%.6g", v[0], v[1], v[2]);
    return std::string(buf);
  };
  if (c.after_log_t_s) {  // none where it came before the log's first sample
    char t[32];
    std::snprintf(t, sizeof t, "%.6g", *c.after_log_t_s);
    log.metadata.emplace_back("collision_t_s", t);
  }
  log.metadata.emplace_back("collision_joint", std::to_string(c.joint));
  log.metadata.emplace_back("collision_residual_Nm", three(c.residual_Nm));
  log.metadata.emplace_back("collision_threshold_Nm", three(c.threshold_Nm));
}

// The session's samples as a delta-log/1 log; i1..i3 only when every sample
// has its drives' currents: never a guess.
DeltaLog session_log(const RecordOptions& o, const Session& session, RecordSummary& summary) {
  const auto& samples = session.samples();
  const auto& currents = session.sample_currents();
  DeltaLog log;
  log.geometry = o.geometry;
  log.sample_rate_hz = o.sample_rate_hz;
  log.metadata.emplace_back("source", "robot");
  log.metadata.emplace_back("can_interface", o.iface);
  if (summary.stale > 0) log.metadata.emplace_back("stale_samples", std::to_string(summary.stale));
  if (summary.collision) add_collision_metadata(*summary.collision, log);
  summary.samples_without_currents =
      static_cast<std::uint64_t>(std::count(currents.begin(), currents.end(), std::nullopt));
  summary.currents = session.currents_seen() && summary.samples_without_currents == 0;
  if (summary.currents) {
    const char* names[] = {"i1", "i2", "i3"};
    for (unsigned j = 0; j < 3; ++j) {
      Series column;
      for (const auto& c : currents) column.push_back((*c)[j] * o.rated_current_A / 1000.0);
      log.extra_columns.emplace_back(names[j], std::move(column));
    }
  }
  if (!session.currents_seen()) summary.samples_without_currents = 0;
  summary.arm_encoders = session.arm_encoders();
  if (summary.arm_encoders) {
    const char* names[] = {"qa1", "qa2", "qa3"};
    for (unsigned j = 0; j < 3; ++j) {
      Series column;
      column.reserve(samples.size());
      for (const LogSample& s : samples) column.push_back(s.qa_rad[j]);
      log.extra_columns.emplace_back(names[j], std::move(column));
    }
  }
  const std::uint64_t first = samples.front().seq;
  for (const LogSample& s : samples) {
    log.seq.push_back(s.seq - first);
    log.t.push_back(static_cast<double>(s.seq - first) / o.sample_rate_hz);
    for (unsigned j = 0; j < 3; ++j) {
      log.q[j].push_back(s.q_rad[j]);
      log.tau[j].push_back(s.tau_Nm[j]);
    }
  }
  return log;
}

}  // namespace

Recording capture(const RecordOptions& o, const std::function<void()>& ready) {
  delta::require_valid_geometry(o.geometry);
  if (!(o.sample_rate_hz > 0)) throw delta::InputError("record: --rate must be positive");
  if (o.duration_s <= 0 && o.samples == 0 && o.idle_s <= 0 && !o.keep_going) {
    throw delta::InputError("record: give a limit: --duration S, --samples N or --idle S");
  }
  delta::can::Socket sock = open_socket(o);
  if (ready) ready();
  Session session(o);
  session.run(sock);
  RecordSummary summary = session.summary();
  if (session.samples().empty()) {
    throw delta::InputError("record: no complete log sample arrived on " + o.iface + " (" +
                            missing_log_frames(session.assembler()) + "); nothing written");
  }
  DeltaLog log = session_log(o, session, summary);
  return Recording{std::move(log), summary, std::move(session.raw())};
}

}  // namespace host_id
