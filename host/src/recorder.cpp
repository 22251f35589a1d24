#include "host_id/recorder.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <ostream>
#include <sstream>

#include "delta/can/protocol.hpp"
#include "delta/input_error.hpp"
#include "host_id/atomic_file.hpp"

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
  const auto seq = unwrap(static_cast<std::uint32_t>(p::unpack(f.data, kLogA.signals[0])));
  const bool stale = p::unpack(f.data, kLogA.signals[3]) != 0;
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
    s.q_rad[0] = scaled(kLogA.signals[1], p::unpack(f.data, kLogA.signals[1]));
    s.q_rad[1] = scaled(kLogA.signals[2], p::unpack(f.data, kLogA.signals[2]));
  } else if (part == 1) {
    s.q_rad[2] = scaled(kLogB.signals[1], p::unpack(f.data, kLogB.signals[1]));
    s.tau_Nm[0] = scaled(kLogB.signals[2], p::unpack(f.data, kLogB.signals[2]));
  } else {
    s.tau_Nm[1] = scaled(kLogC.signals[1], p::unpack(f.data, kLogC.signals[1]));
    s.tau_Nm[2] = scaled(kLogC.signals[2], p::unpack(f.data, kLogC.signals[2]));
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
      const std::uint64_t missing = x.seq - *next_to_emit_;
      append_run(gaps_, *next_to_emit_, missing);
      lost_ += missing;
      next_to_emit_ = x.seq;
      continue;
    }
    if (!complete) {
      if (x.seq >= give_up_below) break;
      append_run(gaps_, x.seq, 1);
      ++lost_;
    } else if (x.sample.stale) {
      // Not a sample: the controller said a drive's feedback missed it.
      append_run(stale_runs_, x.seq, 1);
      ++stale_;
    } else {
      complete_.push_back(x.sample);
    }
    next_to_emit_ = x.seq + 1;
    ++i;
  }
  pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(i));
}

std::vector<LogSample> LogAssembler::take_complete() {
  std::vector<LogSample> out;
  out.swap(complete_);
  return out;
}

void LogAssembler::finish() {
  if (!next_to_emit_) return;
  emit_up_to(UINT64_MAX);  // gives up on every cycle still pending: each is lost
}

void DriveCurrentTracker::feed(const delta::can::Frame& f) {
  if (f.extended || f.error_frame || f.remote) return;
  if (f.id == kLogA.base_id && f.dlc == 8) {
    if (fresh_ == 0x7) {
      const auto seq15 = static_cast<std::uint16_t>(p::unpack(f.data, kLogA.signals[0]));
      by_seq_.emplace_back(seq15, current_pm_);
      if (by_seq_.size() > 4 * kReorderWindow) by_seq_.erase(by_seq_.begin());
    }
    fresh_ = 0;
    return;
  }
  const std::uint32_t base = p::kTpdo1.base_id;
  if (f.id > base && f.id <= base + p::kDriveCount && f.dlc == p::kTpdo1.dlc) {
    const unsigned j = f.id - base - p::kFirstDriveNode;
    current_pm_[j] = static_cast<std::int16_t>(p::unpack(f.data, p::kTpdo1.signals[2]));
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

void report_left_out(std::ostream& err, const std::string& who, const RecordSummary& s) {
  for (const auto& [first, count] : s.gaps) {
    err << who << ": lost " << count << " sample(s) from seq " << first
        << " (log frames missing)\n";
  }
  for (const auto& [first, count] : s.stale_runs) {
    err << who << ": left out " << count << " sample(s) from seq " << first
        << ": the controller marked them stale (a drive's feedback missed the cycle)\n";
  }
}

RecordSummary record(const RecordOptions& o, const std::function<void()>& ready) {
  Recording r = capture(o, ready);
  write_file_atomically(o.out_path, format_delta_log(r.log));
  if (o.raw_path) write_file_atomically(*o.raw_path, r.raw);
  return r.summary;
}

Recording capture(const RecordOptions& o, const std::function<void()>& ready) {
  delta::require_valid_geometry(o.geometry);
  if (!(o.sample_rate_hz > 0)) throw delta::InputError("record: --rate must be positive");
  if (o.duration_s <= 0 && o.samples == 0 && o.idle_s <= 0 && !o.keep_going) {
    throw delta::InputError("record: give a limit: --duration S, --samples N or --idle S");
  }
  delta::can::Socket sock = [&] {
    try {
      // With --raw, every frame of the session (a candump of it); else only
      // the log frames.
      std::vector<delta::can::Filter> filters;
      if (!o.raw_path) {
        filters = {{kLogA.base_id, 0x7FF, false},
                   {kLogB.base_id, 0x7FF, false},
                   {kLogC.base_id, 0x7FF, false},
                   {p::kTpdo1.base_id, 0x780, false}};  // the drives' currents
      }
      return delta::can::Socket::open(o.iface, filters,
                                      8 << 20);  // 8 MB: about 10 000 frames of burst
    } catch (const delta::can::CanError& e) {
      throw delta::InputError(std::string("record: ") + e.what());
    }
  }();
  if (ready) ready();
  LogAssembler assembler;
  DriveCurrentTracker currents;
  std::vector<LogSample> samples;
  std::vector<std::optional<std::array<std::int16_t, 3>>> sample_currents;
  std::string raw;
  RecordSummary summary;
  const auto t0 = std::chrono::steady_clock::now();
  // --idle counts from the latest log frame, and only once one came: a
  // controller may take a while to bring its drives up before it logs.
  std::optional<std::chrono::steady_clock::time_point> last_log_frame;
  const auto elapsed = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  for (;;) {
    if (o.keep_going && !o.keep_going(samples.size() + assembler.stale_samples())) break;
    if (o.duration_s > 0 && elapsed() >= o.duration_s) break;
    if (o.samples > 0 && samples.size() >= o.samples) break;
    if (o.idle_s > 0 && last_log_frame &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - *last_log_frame).count() >=
            o.idle_s)
      break;
    if (!sock.wait_readable(std::chrono::milliseconds(50))) continue;
    while (auto r = sock.receive()) {
      ++summary.frames;
      summary.socket_drops = r->socket_drops;
      if (o.raw_path) {
        char buf[96];
        const auto ns = r->kernel_time.count();
        // candump -L: 3 hex digits for a standard ID, 8 for an extended or
        // error frame (with its flag bit), R for a remote request.
        const delta::can::Frame& f = r->frame;
        const std::uint32_t id =
            f.error_frame ? (0x20000000u | f.id) : (f.extended ? (0x80000000u | f.id) : f.id);
        std::snprintf(
            buf, sizeof buf,
            (f.error_frame || f.extended) ? "(%lld.%06lld) %s %08X#" : "(%lld.%06lld) %s %03X#",
            static_cast<long long>(ns / 1000000000),
            static_cast<long long>((ns % 1000000000) / 1000), o.iface.c_str(),
            f.extended ? (id & 0x1FFFFFFFu) : id);
        raw += buf;
        if (f.remote) raw += 'R';
        for (unsigned i = 0; !f.remote && i < r->frame.dlc; ++i) {
          std::snprintf(buf, sizeof buf, "%02X", r->frame.data[i]);
          raw += buf;
        }
        raw += '\n';
      }
      if (!r->error) currents.feed(r->frame);
      if (!r->error && assembler.feed(r->frame)) last_log_frame = std::chrono::steady_clock::now();
      for (auto& s : assembler.take_complete()) {
        samples.push_back(s);
        sample_currents.push_back(currents.take(s.seq));
      }
      if (o.samples > 0 && samples.size() >= o.samples) break;
    }
  }
  assembler.finish();
  for (auto& s : assembler.take_complete()) {
    samples.push_back(s);
    sample_currents.push_back(currents.take(s.seq));
  }
  if (o.samples > 0 && samples.size() > o.samples) {
    samples.resize(o.samples);
    sample_currents.resize(o.samples);
  }
  summary.seconds = elapsed();
  summary.samples = samples.size();
  summary.lost = assembler.lost_samples();  // dropped frames show up as incomplete cycles
  summary.gaps = assembler.gaps();
  summary.stale = assembler.stale_samples();
  summary.stale_runs = assembler.stale_runs();
  if (samples.empty()) {
    throw delta::InputError("record: no complete log sample arrived on " + o.iface +
                            " (controller log frames 0x" +
                            [] {
                              char b[8];
                              std::snprintf(b, sizeof b, "%03X", kLogA.base_id);
                              return std::string(b);
                            }() +
                            ".. ); nothing written");
  }
  DeltaLog log;
  log.geometry = o.geometry;
  log.sample_rate_hz = o.sample_rate_hz;
  log.metadata.emplace_back("source", "robot");
  log.metadata.emplace_back("can_interface", o.iface);
  if (summary.stale > 0) log.metadata.emplace_back("stale_samples", std::to_string(summary.stale));
  const std::uint64_t first = samples.front().seq;
  // i1..i3 only when every sample has its drives' currents: never a guess.
  summary.samples_without_currents = static_cast<std::uint64_t>(
      std::count(sample_currents.begin(), sample_currents.end(), std::nullopt));
  summary.currents = currents.any_seen() && summary.samples_without_currents == 0;
  if (summary.currents) {
    const char* names[] = {"i1", "i2", "i3"};
    for (unsigned j = 0; j < 3; ++j) {
      Series column;
      for (const auto& c : sample_currents) column.push_back((*c)[j] * o.rated_current_A / 1000.0);
      log.extra_columns.emplace_back(names[j], std::move(column));
    }
  }
  if (!currents.any_seen()) summary.samples_without_currents = 0;
  for (const LogSample& s : samples) {
    log.seq.push_back(s.seq - first);
    log.t.push_back(static_cast<double>(s.seq - first) / o.sample_rate_hz);
    for (unsigned j = 0; j < 3; ++j) {
      log.q[j].push_back(s.q_rad[j]);
      log.tau[j].push_back(s.tau_Nm[j]);
    }
  }
  return Recording{std::move(log), summary, std::move(raw)};
}

}  // namespace host_id
