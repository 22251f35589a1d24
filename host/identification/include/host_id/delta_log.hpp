// The delta-log/1 file format (docs/log-format.md, docs/conventions.md):
// a strict reader that rejects every breach of the contract with
// file:line:column, and a writer that round-trips every double exactly.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "delta/atomic_file.hpp"
#include "delta/geometry.hpp"

namespace host_id {

using Series = std::vector<double>;
using Series3 = std::array<Series, 3>;

// A place where samples are not contiguous: samples [0, index) and
// [index, ...) must never be bridged by filtering or differentiation.
struct SampleGap {
  std::size_t index{};  // first sample after the gap
  std::size_t line{};   // its line in the file
  std::string what;     // e.g. "seq jumps from 41 to 45 (3 samples lost)"
};

struct DeltaLog {
  std::string name;  // the file it came from, for messages
  delta::Geometry geometry{};
  double gravity_m_s2{9.81};
  std::optional<double> sample_rate_hz;
  // Every metadata key in file order, required, optional and unknown alike.
  std::vector<std::pair<std::string, std::string>> metadata;

  Series t;     // s
  Series3 q;    // rad
  Series3 tau;  // N m
  bool has_qd{false};
  bool has_qdd{false};
  Series3 qd;                      // rad/s, when has_qd
  Series3 qdd;                     // rad/s^2, when has_qdd
  std::vector<std::uint64_t> seq;  // empty when the log has no seq column
  // Further columns, kept by name.
  std::vector<std::pair<std::string, Series>> extra_columns;

  std::vector<SampleGap> gaps;
  std::size_t first_data_line{0};

  std::size_t size() const { return t.size(); }
  // The value of a metadata key, if present.
  std::optional<std::string> metadata_value(std::string_view key) const;
};

// Parses text as delta-log/1; name is used in messages ("name:line:col: ...").
// Throws delta::InputError on any breach of the contract.
DeltaLog parse_delta_log(std::string_view text, const std::string& name);

// Reads and parses a file.
DeltaLog read_delta_log(const std::string& path);

// Formats a log as delta-log/1 text. Numbers are written in the shortest form
// that reads back to the same double.
std::string format_delta_log(const DeltaLog& log);

// The same, written to path atomically a piece at a time: the text of an
// hour-long log is never held whole (docs/dev/performance.md).
void write_delta_log_atomically(const std::string& path, const DeltaLog& log);
// Into a writer the caller commits (with other outputs: commit_together).
void write_delta_log(delta::AtomicFileWriter& w, const DeltaLog& log);

// Frees the sample columns (t, q, tau, qd, qdd, seq, extra columns); the
// name, metadata and gaps stay.
void release_samples(DeltaLog& log);

// What a command should say of a log it fits, validates or predicts: time
// steps that spread (check_time_steps), a derivative group given without
// the other (then unused), columns the model does not read, and one line
// per gap ("LOG:LINE: warning: ...; segments are fitted separately"), the
// first kGapWarningsShown of them, then one line counting the rest.
inline constexpr std::size_t kGapWarningsShown = 10;

// How the times of a log's samples are taken where q is differentiated
// (docs/preprocessing.md, "Timestamps"):
//   kCheck    the time steps must be even: a spread above kTimeStepError
//             is refused, one above kTimeStepWarning is warned of;
//   kNominal  the samples were taken evenly and only their timestamps
//             jitter (a host-side logger): differentiate at the declared
//             rate's step, else the segment's mean step;
//   kAsLogged the samples were taken at their timestamps: differentiate
//             on them, however uneven.
enum class TimeSteps : std::uint8_t { kCheck, kNominal, kAsLogged };
inline constexpr double kTimeStepWarning = 0.01;
inline constexpr double kTimeStepError = 0.05;

// The spread of a log's time steps within its segments (gaps left out),
// relative to the median step: robust (1.4826 MAD, a standard deviation for
// Gaussian jitter) and the largest departure.
struct TimeStepSpread {
  double median_s{0};
  double spread{0};
  double largest{0};
};
TimeStepSpread time_step_spread(const DeltaLog& log);

// With kCheck: throws InputError where the log's time steps spread more
// than kTimeStepError (q differentiated, not logged), naming the spread and
// the options. Returns the warning (without the log's name) for a spread
// above kTimeStepWarning, else "".
std::string check_time_steps(const DeltaLog& log, TimeSteps mode);

void warn_about_log(std::ostream& err, const DeltaLog& log, TimeSteps mode = TimeSteps::kCheck);

// Spans (first and last sample's t) of at least kStallMinSeconds in which
// every joint's torque stays within kStallTorqueFraction of its RMS: the
// arms of a delta always carry its weight, so there the drives gave no
// torque (disabled or faulted mid-run). warn_about_log names each.
inline constexpr double kStallTorqueFraction = 0.005;
inline constexpr double kStallMinSeconds = 0.1;
std::vector<std::pair<double, double>> torque_stalls(const DeltaLog& log);

// Where the time column looks like milliseconds (its median step a
// thousand times the declared one, or, undeclared, 0.5 to 20 s: a robot is
// not logged at 0.05-2 Hz): "t looks like milliseconds: ...", the advice
// an error about the rate gives; else "".
std::string milliseconds_hint(double median_step_s, std::optional<double> declared_rate_hz);

// Shortest round-trip decimal form of a double.
std::string format_number(double v);

}  // namespace host_id
