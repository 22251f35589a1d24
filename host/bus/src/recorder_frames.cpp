// The recorder's frame assembly: LOG_A..E frames paired into samples, the
// drives' currents matched to them, and the emergencies seen.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "delta/can/cia402.hpp"
#include "delta/can/emcy.hpp"
#include "delta/can/protocol.hpp"
#include "host_id/recorder.hpp"

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

// The log frame's part (0 to 4: LOG_A to LOG_E), -1 for any other frame.
int log_part(const delta::can::Frame& f) {
  const p::Message* parts[] = {&kLogA, &kLogB, &kLogC, &p::kLogD, &p::kLogE};
  for (int i = 0; i < 5; ++i) {
    if (f.id == parts[i]->base_id && f.dlc == parts[i]->dlc) return i;
  }
  return -1;
}

// Every log frame's seq and stale are read with LOG_A's signals.
constexpr bool same_bits(const p::Signal& a, const p::Signal& b) {
  return a.start_bit == b.start_bit && a.length == b.length;
}
static_assert(same_bits(p::kLogASeq, p::kLogBSeq) && same_bits(p::kLogASeq, p::kLogCSeq) &&
              same_bits(p::kLogASeq, p::kLogDSeq) && same_bits(p::kLogASeq, p::kLogESeq));
static_assert(same_bits(p::kLogAStale, p::kLogBStale) && same_bits(p::kLogAStale, p::kLogCStale) &&
              same_bits(p::kLogAStale, p::kLogDStale) && same_bits(p::kLogAStale, p::kLogEStale));

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
  if (f.extended) return false;
  const int part = log_part(f);
  if (part < 0) return false;
  parts_seen_ |= 1u << part;
  if (part >= 3 && !arm_) arm_ = true;
  if (part >= 3 && !*arm_) {  // a cycle without them came first: not this log's
    ++arm_frames_left_out_;
    return true;
  }
  // seq and stale sit in the same bits of all five frames.
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
  } else if (part == 2) {
    s.tau_Nm[1] = scaled(p::kLogCTau2, p::unpack(f.data, p::kLogCTau2));
    s.tau_Nm[2] = scaled(p::kLogCTau3, p::unpack(f.data, p::kLogCTau3));
  } else if (part == 3) {
    s.qa_rad[0] = scaled(p::kLogDQa1, p::unpack(f.data, p::kLogDQa1));
    s.qa_rad[1] = scaled(p::kLogDQa2, p::unpack(f.data, p::kLogDQa2));
  } else {
    s.qa_rad[2] = scaled(p::kLogEQa3, p::unpack(f.data, p::kLogEQa3));
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
    if (!decided_whole(x)) break;
    const bool complete = (x.parts & whole()) == whole();
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

// Whether the cycle's frames can be judged: the first cycle with LOG_A..C
// decides whether the log has LOG_D and LOG_E, once a frame of a later
// cycle (or the end, finish()) shows that no more of its frames come.
bool LogAssembler::decided_whole(const Pending& x) {
  if (arm_ || (x.parts & 0x07) != 0x07) return true;
  if (*last_seq_ <= x.seq) return false;
  arm_ = false;
  return true;
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
  if (!arm_) arm_ = false;  // no LOG_D or LOG_E came
  // Cycles after the last complete one were cut off by the end of the
  // recording; the log has no gap for them.
  std::uint64_t end = *next_to_emit_;
  for (const Pending& x : pending_) {
    if ((x.parts & whole()) == whole()) end = std::max(end, x.seq + 1);
  }
  if (*last_seq_ >= end) {
    cut_off_ = {end, *last_seq_ - end + 1};
    std::erase_if(pending_, [end](const Pending& x) { return x.seq >= end; });
  }
  emit_up_to(UINT64_MAX);  // gives up on every cycle still pending: each is lost
}

std::string missing_log_frames(const LogAssembler& a) {
  const p::Message* parts[] = {&kLogA, &kLogB, &kLogC, &p::kLogD, &p::kLogE};
  const unsigned wanted = a.arm_encoders() ? 0x1F : 0x07;
  const unsigned seen = a.parts_seen();
  if (seen == 0) return "no controller log frame came: LOG_A 0x190, LOG_B 0x290, LOG_C 0x390";
  std::string missing;
  for (unsigned i = 0; i < 5; ++i) {
    if ((wanted >> i & 1u) == 0 || (seen >> i & 1u) != 0) continue;
    char id[8];
    std::snprintf(id, sizeof id, "%03X", parts[i]->base_id);
    missing += std::string(missing.empty() ? "" : ", ") + parts[i]->name + " 0x" + id;
  }
  if (missing.empty()) return "each log frame came, but never all of one cycle";
  return "these log frames never came: " + missing +
         (a.arm_encoders() ? " (the arm encoders' frames did: is the recorder filtering them?)"
                           : "");
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

void CollisionWatch::feed(const delta::can::Frame& f, std::optional<double> log_t_s) {
  if (f.extended || f.remote || f.error_frame) return;
  if (f.id != p::kCollision.base_id || f.dlc != p::kCollision.dlc) return;
  const auto joint = static_cast<unsigned>(p::unpack(f.data, p::kCollisionJoint));
  if (joint < 1 || joint > 3) return;
  if (!seen_) {
    seen_.emplace();
    seen_->joint = static_cast<unsigned>(p::unpack(f.data, p::kCollisionTripped));
    seen_->after_log_t_s = log_t_s;
  }
  // The first collision's frames only: they come in one cycle, after the
  // same log sample; a joint's frame once.
  const auto bit = static_cast<std::uint8_t>(1u << (joint - 1));
  if (log_t_s != seen_->after_log_t_s || (seen_->joints_seen & bit) != 0) return;
  seen_->residual_Nm[joint - 1] =
      scaled(p::kCollisionResidual, p::unpack(f.data, p::kCollisionResidual));
  seen_->threshold_Nm[joint - 1] =
      scaled(p::kCollisionThreshold, p::unpack(f.data, p::kCollisionThreshold));
  seen_->joints_seen = static_cast<std::uint8_t>(seen_->joints_seen | bit);
}

}  // namespace host_id
