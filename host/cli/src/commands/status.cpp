// host_id status --modbus HOST:PORT: the controller's state, faults,
// settings and live values over Modbus (docs/modbus.md).
#include <iomanip>
#include <memory>
#include <ostream>

#include "commands/command.hpp"
#include "host_id/controller_link.hpp"
#include "host_id/controller_text.hpp"

namespace host_id {

namespace {

namespace mb = delta::modbus;

struct StatusArguments {
  std::string address;
  bool json{false};
};

void print_json(const std::vector<std::uint16_t>& in, const std::vector<std::uint16_t>& hold,
                std::ostream& out) {
  out << "{";
  bool first = true;
  for (const mb::Register& reg : mb::kRegisters) {
    const auto& table = reg.table == mb::Table::kInput ? in : hold;
    out << (first ? "" : ",") << "\n  \"" << reg.name << "\": " << mb::decode(reg, table.data());
    first = false;
  }
  out << "\n}\n";
}

void print_state_and_safety(const std::vector<std::uint16_t>& in, std::ostream& out) {
  const auto r = [&](const char* name) { return raw(name, in); };
  const std::int64_t io = r("io");
  out << "  state      " << state_text(r("state"));
  if (r("fault_code") != 0) out << ", fault " << fault_text(r("fault_code"));
  out << "\n  cycle      " << r("cycle_counter") << " (period " << r("period_us") << " us)\n";
  out << "  safety     e-stop " << ((io & mb::kIoEStopOpen) ? "OPEN" : "closed") << ", drives "
      << ((io & mb::kIoDriveEnable) ? "enabled" : "disabled") << ", brake "
      << ((io & mb::kIoBrakeReleased) ? "released" : "engaged") << ", status "
      << ((io & mb::kIoStatusOk) ? "ok" : "fault") << ", log frames "
      << ((io & mb::kIoLogEnabled) ? "on" : "off") << "\n";
}

void print_run_and_settings(const std::vector<std::uint16_t>& in,
                            const std::vector<std::uint16_t>& hold, std::ostream& out) {
  const auto r = [&](const char* name) { return raw(name, in); };
  out << "  run        ";
  if (r("run_id") == 0) {
    out << "none since start";
  } else {
    out << "#" << r("run_id") << " " << run_result_text(r("run_result")) << ", tick "
        << r("run_tick") << " of " << r("run_length");
  }
  out << "; " << r("log_records") << " log records sent";
  if (r("stale_log_records") != 0) out << " (" << r("stale_log_records") << " marked stale)";
  out << "\n";
  if (r("tracking_run_id") != 0) {
    // The controller's own measurement of the run's trajectory.
    out << std::setprecision(3) << "  tracking   run #" << r("tracking_run_id") << ", rms "
        << scaled("tracking_rms_1", in) << " " << scaled("tracking_rms_2", in) << " "
        << scaled("tracking_rms_3", in) << " rad, max " << scaled("tracking_max_1", in) << " "
        << scaled("tracking_max_2", in) << " " << scaled("tracking_max_3", in) << " rad over "
        << r("tracking_ticks") << " cycles\n";
  }
  out << "  collision  " << (r("collision_detect") != 0 ? "detector on" : "detector off");
  if (r("collision_joint") != 0) {
    out << std::setprecision(4) << "; last of " << r("collision_count") << ": joint "
        << r("collision_joint") << " at t_s=" << scaled("collision_t", in) << ", residual "
        << scaled("collision_residual_1", in) << " " << scaled("collision_residual_2", in) << " "
        << scaled("collision_residual_3", in) << " N m against "
        << scaled("collision_threshold_1", in) << " " << scaled("collision_threshold_2", in) << " "
        << scaled("collision_threshold_3", in) << " N m";
  }
  out << "\n";
  static const char* const kModes[] = {"off", "nominal", "the identified model"};
  const std::int64_t mode = r("feed_forward_mode");
  out << "  feed-fwd   " << (mode >= 0 && mode < 3 ? kModes[mode] : "unknown");
  if (r("model_fit_id") != 0)
    out << "; model fit " << hex32(static_cast<std::uint32_t>(r("model_fit_id")));
  out << "\n";
  const std::int64_t reps = hold[mb::kRepetitions.address];
  out << "  settings   trajectory " << trajectory_name(hold[mb::kTrajectory.address])
      << ", amplitude " << std::setprecision(1) << hold[mb::kAmplitudeScale.address] / 10.0
      << " %, repetitions " << (reps == 0 ? std::string("preset") : std::to_string(reps)) << "\n";
}

void print_values_and_faults(const std::vector<std::uint16_t>& in, std::ostream& out) {
  const auto r = [&](const char* name) { return raw(name, in); };
  out << std::setprecision(4) << "  q          " << scaled("q1", in) << " " << scaled("q2", in)
      << " " << scaled("q3", in) << " rad\n";
  out << "  tau        " << scaled("tau1", in) << " " << scaled("tau2", in) << " "
      << scaled("tau3", in) << " N m (last run)\n";
  out << "  faults     " << r("fault_count") << " since start";
  for (unsigned k = 0; k < mb::kFaultHistoryLength; ++k) {
    const std::int64_t code = mb::decode(mb::fault_history_code(k), in.data());
    if (code == 0) break;
    const std::int64_t cycle = mb::decode(mb::fault_history_cycle(k), in.data());
    out << (k == 0 ? ": " : "; ") << fault_text(code) << " at cycle " << cycle;
  }
  out << "\n  geometry   upper arm " << scaled("upper_arm_length", in) << " m, forearm "
      << scaled("forearm_length", in) << " m, base radius " << scaled("base_radius", in)
      << " m, platform radius " << scaled("platform_radius", in) << " m\n";
  if (r("last_rejection") != 0) {
    const mb::Register* reg =
        mb::find(mb::Table::kHolding, static_cast<std::uint16_t>(r("last_rejection_register")));
    out << "  refused    last: " << mb::describe(static_cast<mb::Rejection>(r("last_rejection")))
        << " (register " << (reg ? reg->name : "?") << ")\n";
  }
}

int run_status(const StatusArguments& a, std::ostream& out) {
  ControllerLink link(a.address);
  const std::vector<std::uint16_t> in = link.inputs();
  const std::vector<std::uint16_t> hold = link.holding();
  if (a.json) {
    print_json(in, hold, out);
    return 0;
  }
  out << std::fixed;
  out << "controller " << link.address() << ": firmware " << raw("firmware_version_major", in)
      << "." << raw("firmware_version_minor", in) << "." << raw("firmware_version_patch", in)
      << ", register map " << raw("protocol_version", in) << "\n";
  print_state_and_safety(in, out);
  print_run_and_settings(in, hold, out);
  print_values_and_faults(in, out);
  return 0;
}

}  // namespace

void add_status_command(CLI::App& command, CommandContext& context) {
  CLI::App* c = &command;
  c->description(
      "Reads the controller's state over Modbus TCP (docs/modbus.md): firmware and register map "
      "versions, state and fault, the fault history, the run, the safety lines, the settings, "
      "the live joint angles and torques, and the geometry.");
  auto a = std::make_shared<StatusArguments>();
  c->add_option("--modbus", a->address, "the controller's Modbus TCP address")
      ->required()
      ->check(kHostPort);
  c->add_flag("--json", a->json, "every register, as JSON");
  c->callback([a, &context] { context.exit_code = run_status(*a, context.out); });
}

}  // namespace host_id
