// host_id record --can IFACE -o LOG.csv: the controller's CAN log frames to
// a delta-log/1 file.
#include <memory>
#include <ostream>

#include "commands/command.hpp"
#include "host_id/recorder.hpp"

namespace host_id {

namespace {

constexpr const char* kRecordDescription =
    "Records the controller's log frames (LOG_A..LOG_E, docs/protocol.md) from a CAN interface "
    "into delta-log/1, with the drives' motor currents (TPDO1) as columns i1..i3 when every "
    "sample has them, and the arm-side encoders (LOG_D, LOG_E, sent with the controller's "
    "arm_encoders = true) as columns qa1..qa3. Samples are paired by their sequence counter; a "
    "lost sample is reported "
    "and the log keeps its seq column, so no gap is ever bridged. A cycle the controller marked "
    "stale (a drive's feedback missed it) is left out the same way and reported, but is not "
    "lost. A cycle the recording began or ended inside (incomplete before the first or after "
    "the last complete one) is cut off and reported, and is not a gap. Exit status 3 when "
    "samples were lost (unless --allow-gaps).";

struct RecordArguments {
  RecordOptions record;
  std::string raw_path;
  bool allow_gaps{false};
  bool quiet{false};
  bool json{false};
};

void add_limit_options(CLI::App& c, RecordOptions& r) {
  const char* g = "limits (at least one)";
  c.add_option("--duration", r.duration_s, "stop after S seconds")->check(kPositive)->group(g);
  c.add_option("--samples", r.samples, "stop after N complete samples")
      ->check(CLI::Range(std::uint64_t{1}, UINT64_MAX))
      ->group(g);
  c.add_option("--idle", r.idle_s,
               "stop when no log frame came for S seconds, counted from the first log frame")
      ->check(kPositive)
      ->group(g);
}

void add_geometry_options(CLI::App& c, delta::Geometry& g) {
  const char* group = "the robot's geometry for the metadata (default robot)";
  c.add_option("--upper-arm-m", g.upper_arm_length_m)->check(kPositive)->group(group);
  c.add_option("--forearm-m", g.forearm_length_m)->check(kPositive)->group(group);
  c.add_option("--base-radius-m", g.base_radius_m)->check(kPositive)->group(group);
  c.add_option("--platform-radius-m", g.platform_radius_m)->check(kPositive)->group(group);
}

int run_record(const RecordArguments& a, std::ostream& out, std::ostream& err) {
  RecordOptions r = a.record;
  if (r.duration_s <= 0 && r.samples == 0 && r.idle_s <= 0) {
    throw UsageError("record: give a limit: --duration S, --samples N or --idle S");
  }
  if (!a.raw_path.empty()) r.raw_path = a.raw_path;
  // The line tells scripts and tests that the socket is open.
  const RecordSummary s = record(r, [&] {
    if (!a.quiet) err << "host_id record: listening on " << r.iface << std::endl;
  });
  if (a.json) {
    nlohmann::json j = json_summary(s);
    j["log"] = r.out_path;
    j["interface"] = r.iface;
    out << j.dump(2) << "\n";
  } else if (!a.quiet) {
    out << "host_id record: " << s.samples << " samples (" << s.frames << " frames) from "
        << r.iface << " in " << s.seconds << " s -> " << r.out_path
        << (s.currents ? " (with the drives' currents i1..i3)" : "")
        << (s.arm_encoders ? " (with the arm-side encoders qa1..qa3)" : "") << "\n";
  }
  report_left_out(err, "host_id record", s);
  report_emergencies(err, "host_id record", s);
  if (s.socket_drops)
    err << "host_id record: the kernel dropped " << s.socket_drops << " frames for this reader\n";
  if (s.samples_without_currents > 0) {
    err << "host_id record: " << s.samples_without_currents
        << " samples came without all three drives' TPDO1; the i1..i3 columns are left out\n";
  }
  if (s.lost > 0 && !a.allow_gaps) {
    err << "host_id record: " << s.lost
        << " samples lost; the log keeps them as gaps in seq (--allow-gaps to accept)\n";
    return 3;
  }
  return 0;
}

}  // namespace

void add_record_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(kRecordDescription);
  auto a = std::make_shared<RecordArguments>();
  RecordOptions& r = a->record;
  c->add_option("--can", r.iface, "the CAN interface (can0, vcan0)")->required();
  c->add_option("-o,--out", r.out_path, "the log to write (atomically)")
      ->check(kOutputPath)
      ->required();
  add_limit_options(*c, r);
  c->add_option("--rate", r.sample_rate_hz, "the controller's cycle rate, for t")
      ->check(kPositive)
      ->capture_default_str();
  c->add_option("--raw", a->raw_path,
                "also write every frame of the session (all IDs) in candump -L format, for "
                "canplayer and DBC tools")
      ->check(kOutputPath);
  c->add_option("--rated-current-A", r.rated_current_A,
                "the drives' rated current (0x6075), for the i1..i3 columns in A")
      ->check(kPositive)
      ->capture_default_str();
  c->add_flag("--allow-gaps", a->allow_gaps, "exit 0 even when samples were lost");
  c->add_flag("--quiet", a->quiet, "no listening and summary lines (warnings and errors stay)");
  c->add_flag("--json", a->json, "the summary as JSON on stdout");
  add_geometry_options(*c, r.geometry);
  c->callback([a, &context] { context.exit_code = run_record(*a, context.out, context.err); });
}

}  // namespace host_id
