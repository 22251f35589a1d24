#include "host_id/recorder.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <ostream>
#include <sstream>
#include <thread>

#include "delta/atomic_file.hpp"
#include "delta/can/cia402.hpp"
#include "delta/can/emcy.hpp"
#include "delta/can/protocol.hpp"
#include "delta/controller/vocabulary.hpp"
#include "delta/input_error.hpp"

namespace host_id {

namespace p = delta::can::protocol;

namespace {

using p::kLogA;
using p::kLogB;
using p::kLogC;
// Samples older than this many cycles behind the newest are given up on.
constexpr std::uint64_t kReorderWindow = 64;

double scaled(const p::Signal& s, std::int64_t raw) {
  return static_cast<double>(raw) * s.scale.numerator / s.scale.denominator *
         std::ldexp(1.0, s.scale.power2);
}

// Adds `count` seqs from `first` to runs kept in order, joining the last run
// when they follow it.
void append_run(std::vector<std::pair<std::uint64_t, std::uint64_t>>& runs, std::uint64_t first,
                std::uint64_t count) {
  if (!runs.empty() && runs.back().first + runs.back().second == first) {
    runs.back().second += count;
  } else {
    runs.emplace_back(first, count);
  }
}

}  // namespace

std::uint64_t LogAssembler::unwrap(std::uint32_t seq15) {
  if (!last_seq_) {
    last_seq_ = seq15;
    return seq15;
  }
  // The unwrapped value nearest to the last one.
  constexpr std::uint64_t kModulo = p::kLogSeqModulo;
  const std::uint64_t base = *last_seq_ & ~(kModulo - 1);
  std::uint64_t candidate = base | seq15;
  if (candidate + kModulo / 2 < *last_seq_)
    candidate += kModulo;
  else if (candidate > *last_seq_ + kModulo / 2 && candidate >= kModulo)
    candidate -= kModulo;
  last_seq_ = std::max(*last_seq_, candidate);
  return candidate;
}

bool LogAssembler::feed(const delta::can::Frame& f) {
  if (f.extended || f.dlc != 8) return false;
  int part = -1;
  if (f.id == kLogA.base_id) part = 0;
  if (f.id == kLogB.base_id) part = 1;
  if (f.id == kLogC.base_id) part = 2;
  if (part < 0) return false;
  // seq and stale sit in the same bits of all three frames.
  const auto seq = unwrap(static_cast<std::uint32_t>(p::unpack(f.data, p::kLogASeq)));
  const bool stale = p::unpack(f.data, p::kLogAStale) != 0;
  if (!next_to_emit_) next_to_emit_ = seq;
  if (seq < *next_to_emit_) return true;  // too late: already given up on
  auto it = std::find_if(pending_.begin(), pending_.end(),
                         [seq](const Pending& x) { return x.seq == seq; });
  if (it == pending_.end()) {
    pending_.push_back(Pending{seq, 0, LogSample{seq, {}, {}}});
    it = pending_.end() - 1;
  }
  LogSample& s = it->sample;
  s.stale = s.stale || stale;
  if (part == 0) {
    s.q_rad[0] = scaled(p::kLogAQ1, p::unpack(f.data, p::kLogAQ1));
    s.q_rad[1] = scaled(p::kLogAQ2, p::unpack(f.data, p::kLogAQ2));
  } else if (part == 1) {
    s.q_rad[2] = scaled(p::kLogBQ3, p::unpack(f.data, p::kLogBQ3));
    s.tau_Nm[0] = scaled(p::kLogBTau1, p::unpack(f.data, p::kLogBTau1));
  } else {
    s.tau_Nm[1] = scaled(p::kLogCTau2, p::unpack(f.data, p::kLogCTau2));
    s.tau_Nm[2] = scaled(p::kLogCTau3, p::unpack(f.data, p::kLogCTau3));
  }
  it->parts = static_cast<std::uint8_t>(it->parts | (1u << part));
  // Emit every complete sample in order; give up on those that fell out of
  // the reordering window.
  const std::uint64_t newest = *last_seq_;
  emit_up_to(newest >= kReorderWindow ? newest - kReorderWindow : 0);
  return true;
}

void LogAssembler::emit_up_to(std::uint64_t give_up_below) {
  std::sort(pending_.begin(), pending_.end(),
            [](const Pending& a, const Pending& b) { return a.seq < b.seq; });
  std::size_t i = 0;
  while (i < pending_.size()) {
    const Pending& x = pending_[i];
    const bool complete = x.parts == 7;
    if (x.seq != *next_to_emit_) {
      // A seq is missing entirely; wait unless it is out of the window.
      if (*next_to_emit_ >= give_up_below) break;
      give_up(*next_to_emit_, x.seq - *next_to_emit_);
      next_to_emit_ = x.seq;
      continue;
    }
    if (!complete) {
      if (x.seq >= give_up_below) break;
      give_up(x.seq, 1);
    } else if (x.sample.stale) {
      // Not a sample: the controller said a drive's feedback missed it.
      append_run(stale_runs_, x.seq, 1);
      ++stale_;
    } else {
      complete_.push_back(x.sample);
    }
    emitted_any_ = emitted_any_ || complete;
    next_to_emit_ = x.seq + 1;
    ++i;
  }
  pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(i));
}

// Cycles given up on: lost, or, before the first complete one, cycles the
// recording began inside (the log starts after them, so no gap).
void LogAssembler::give_up(std::uint64_t first_seq, std::uint64_t count) {
  if (emitted_any_) {
    append_run(gaps_, first_seq, count);
    lost_ += count;
    return;
  }
  if (started_inside_.second == 0) started_inside_.first = first_seq;
  started_inside_.second += count;
}

std::vector<LogSample> LogAssembler::take_complete() {
  std::vector<LogSample> out;
  out.swap(complete_);
  return out;
}

void LogAssembler::finish() {
  if (!next_to_emit_) return;
  // Cycles after the last complete one were cut off by the end of the
  // recording; the log has no gap for them.
  std::uint64_t end = *next_to_emit_;
  for (const Pending& x : pending_) {
    if (x.parts == 7) end = std::max(end, x.seq + 1);
  }
  if (*last_seq_ >= end) {
    cut_off_ = {end, *last_seq_ - end + 1};
    std::erase_if(pending_, [end](const Pending& x) { return x.seq >= end; });
  }
  emit_up_to(UINT64_MAX);  // gives up on every cycle still pending: each is lost
}

void DriveCurrentTracker::feed(const delta::can::Frame& f) {
  if (f.extended || f.error_frame || f.remote) return;
  if (f.id == kLogA.base_id && f.dlc == 8) {
    if (fresh_ == 0x7) {
      const auto seq15 = static_cast<std::uint16_t>(p::unpack(f.data, p::kLogASeq));
      by_seq_.emplace_back(seq15, current_pm_);
      if (by_seq_.size() > 4 * kReorderWindow) by_seq_.erase(by_seq_.begin());
    }
    fresh_ = 0;
    return;
  }
  const std::uint32_t base = p::kTpdo1.base_id;
  if (f.id > base && f.id <= base + p::kDriveCount && f.dlc == p::kTpdo1.dlc) {
    const unsigned j = f.id - base - p::kFirstDriveNode;
    current_pm_[j] = static_cast<std::int16_t>(p::unpack(f.data, p::kTpdo1CurrentActual));
    fresh_ = static_cast<std::uint8_t>(fresh_ | (1u << j));
    any_seen_ = true;
  }
}

std::optional<std::array<std::int16_t, 3>> DriveCurrentTracker::take(std::uint64_t seq) {
  const auto seq15 = static_cast<std::uint16_t>(seq % p::kLogSeqModulo);
  for (auto it = by_seq_.begin(); it != by_seq_.end(); ++it) {
    if (it->first == seq15) {
      const auto c = it->second;
      by_seq_.erase(by_seq_.begin(), it + 1);  // older ones are never asked for again
      return c;
    }
  }
  return std::nullopt;
}

void EmergencyWatch::feed(const delta::can::Frame& f, std::optional<double> log_t_s) {
  if (f.extended || f.remote || f.error_frame) return;
  if (p::function_code(f.id) != p::kEmcy.base_id || p::node_id(f.id) == 0) return;  // 0x080: SYNC
  if (seen_.size() >= kKept) {
    ++not_kept_;
    return;
  }
  SeenEmergency e;
  e.node = p::node_id(f.id);
  e.code = static_cast<std::uint16_t>(p::unpack(f.data, p::kEmcyErrorCode));
  e.error_register = static_cast<std::uint8_t>(p::unpack(f.data, p::kEmcyErrorRegister));
  if (e.node == p::kControllerNode) {
    e.fault_code = static_cast<std::uint16_t>(p::unpack(f.data, p::kControllerEmcyFaultCode));
  }
  e.after_log_t_s = log_t_s;
  seen_.push_back(e);
}

std::string describe_emergency(const SeenEmergency& e) {
  char code[48];
  std::snprintf(code, sizeof code, "EMCY 0x%04X", e.code);
  std::ostringstream m;
  if (e.node == p::kControllerNode) {
    m << "the controller (node " << int{e.node} << ") sent " << code;
    if (e.code == delta::can::od::kEmcyErrorReset) {
      m << " (error reset)";
    } else {
      m << ": fault " << e.fault_code << " ("
        << delta::controller::fault_name(static_cast<delta::controller::Fault>(e.fault_code))
        << ")";
    }
  } else {
    m << "node " << int{e.node} << " sent " << code << " (" << delta::can::od::emcy_meaning(e.code)
      << ")";
  }
  std::snprintf(code, sizeof code, "0x%02X", e.error_register);
  m << ", error register " << code;
  if (e.after_log_t_s) {
    m << ", after the log's sample at t = " << *e.after_log_t_s << " s";
  } else {
    m << ", before the log's first sample";
  }
  return m.str();
}

void report_emergencies(std::ostream& err, const std::string& who, const RecordSummary& s) {
  for (const SeenEmergency& e : s.emergencies) {
    err << who << ": " << describe_emergency(e) << "\n";
  }
  if (s.emergencies_not_kept > 0) {
    err << who << ": and " << s.emergencies_not_kept << " more EMCY frame(s)\n";
  }
}

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

nlohmann::json json_summary(const RecordSummary& s) {
  using nlohmann::json;
  const auto runs = [](const std::vector<std::pair<std::uint64_t, std::uint64_t>>& v) {
    json a = json::array();
    for (const auto& [first, count] : v) a.push_back({{"first_seq", first}, {"count", count}});
    return a;
  };
  json emergencies = json::array();
  for (const SeenEmergency& e : s.emergencies) {
    emergencies.push_back({{"node", e.node},
                           {"code", e.code},
                           {"error_register", e.error_register},
                           {"fault_code", e.fault_code},
                           {"after_log_t_s", e.after_log_t_s ? json(*e.after_log_t_s) : json()}});
  }
  return {{"samples", s.samples},
          {"frames", s.frames},
          {"seconds", s.seconds},
          {"lost", s.lost},
          {"gaps", runs(s.gaps)},
          {"stale", s.stale},
          {"stale_runs", runs(s.stale_runs)},
          {"cut_off", {{"first_seq", s.cut_off.first}, {"count", s.cut_off.second}}},
          {"started_inside",
           {{"first_seq", s.started_inside.first}, {"count", s.started_inside.second}}},
          {"socket_drops", s.socket_drops},
          {"currents", s.currents},
          {"samples_without_currents", s.samples_without_currents},
          {"emergencies", emergencies},
          {"emergencies_not_kept", s.emergencies_not_kept}};
}

void report_left_out(std::ostream& err, const std::string& who, const RecordSummary& s) {
  for (const auto& [first, count] : s.gaps) {
    err << who << ": lost " << count << " sample(s) from seq " << first
        << " (log frames missing)\n";
  }
  for (const auto& [first, count] : s.stale_runs) {
    err << who << ": left out " << count << " sample(s) from seq " << first
        << ": the controller marked them stale (a drive's feedback missed the cycle)\n";
  }
  if (const auto [first, count] = s.started_inside; count > 0) {
    err << who << ": the recording began inside " << count << " sample(s) from seq " << first
        << " (their first log frames came before it listened): not written, no gap in the log\n";
  }
  if (const auto [first, count] = s.cut_off; count > 0) {
    err << who << ": the recording ended inside " << count << " sample(s) from seq " << first
        << " (their log frames were incomplete): not written, no gap in the log\n";
  }
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
                 {p::kTpdo1.base_id, p::kFunctionCodeMask, false},
                 {p::kEmcy.base_id, p::kFunctionCodeMask, false}};
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
    return s;
  }
  const std::vector<LogSample>& samples() const { return samples_; }
  const std::vector<std::optional<std::array<std::int16_t, 3>>>& sample_currents() const {
    return sample_currents_;
  }
  bool currents_seen() const { return currents_.any_seen(); }
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
  std::vector<LogSample> samples_;
  std::vector<std::optional<std::array<std::int16_t, 3>>> sample_currents_;
  std::string raw_;
  RecordSummary summary_;
  bool limit_reached_{false};
};

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
    char id[8];
    std::snprintf(id, sizeof id, "%03X", kLogA.base_id);
    throw delta::InputError("record: no complete log sample arrived on " + o.iface +
                            " (controller log frames 0x" + id + ".. ); nothing written");
  }
  DeltaLog log = session_log(o, session, summary);
  return Recording{std::move(log), summary, std::move(session.raw())};
}

}  // namespace host_id
