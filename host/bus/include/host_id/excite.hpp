// host_id excite: select and start an excitation on the controller over
// Modbus, record its CAN log frames meanwhile, stop when the run ends, and
// write the log (docs/modbus.md, docs/hil.md).
#pragma once

#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "host_id/recorder.hpp"

namespace host_id {

struct ExciteOptions {
  std::string address;          // the controller's Modbus TCP HOST:PORT
  std::string trajectory;       // a named trajectory, or "custom" with trajectory_file
  std::string trajectory_file;  // uploaded as the custom trajectory
  std::string iface;
  std::string out_path;
  double amplitude_scale{1.0};
  std::uint16_t repetitions{0};  // 0: the trajectory's own
  std::string raw_path;
  double rated_current_A{2.0};
  double timeout_s{0};  // 0: no limit on the whole run (a stall still ends it)
  bool quiet{false};    // no running line and no progress; the closing lines only with json
  bool json{false};     // the closing summary as JSON on out
};

// Exit statuses: 0 finished, 3 samples lost, 4 run not finished (the log
// is then kept as LOG.partial.csv).
constexpr int kExitExciteSamplesLost = 3;
constexpr int kExitExciteNotFinished = 4;

// Runs the excitation and writes its log; Ctrl-C stops the run. Returns the
// exit status; throws delta::InputError where nothing could be written (the
// controller not ready, no sample recorded).
int run_excite(const ExciteOptions& o, std::ostream& out, std::ostream& err);

// Why the run ended early, from one poll of the controller's input
// registers: another client's run, a fault, a stop; an empty text when it
// finished; nothing while it goes on.
std::optional<std::string> poll_ending(const std::vector<std::uint16_t>& inputs,
                                       std::int64_t run_id);

// What the run and its recording come to: ending is empty for a finished
// run; sent is the records the controller sent (UINT64_MAX when unknown).
struct ExciteVerdict {
  int exit_code{0};
  std::string message;  // for stderr; empty when all is well
};
ExciteVerdict excite_verdict(const std::string& ending, const RecordSummary& summary,
                             std::uint64_t sent, const std::string& log_path);

// The recorder's options for the controller whose inputs these are: its
// cycle's rate and its geometry.
RecordOptions record_options(const ExciteOptions& o, const std::vector<std::uint16_t>& inputs);

}  // namespace host_id
