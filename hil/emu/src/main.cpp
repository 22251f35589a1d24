// delta_drive_emu: three emulated CiA 402 drives and the robot they move, on
// a SocketCAN interface (docs/hil.md).
#include <poll.h>
#include <time.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <charconv>
#include <cmath>
#include <csignal>
#include <iostream>
#include <map>
#include <optional>
#include <string>

#include "delta/can/protocol.hpp"
#include "delta/can/socketcan.hpp"
#include "delta/input_error.hpp"
#include "delta/monotonic_clock.hpp"
#include "delta/parameter_file.hpp"
#include "delta/robot_description.hpp"
#include "emu/emulator.hpp"
#include "emu/frame_pump.hpp"

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) {
  g_stop.store(true);
}

// Frames handed to the emulator between two wall-clock checks.
constexpr std::size_t kFramesPerPass = 64;

using delta::monotonic_us;

constexpr const char* kDescription =
    "Emulates three CiA 402 drives (nodes 1-3) and the default delta robot they move "
    "(docs/hil.md). Prints 'delta_drive_emu: ready on IFACE' on stdout once listening; stops on "
    "SIGINT or SIGTERM and prints the drives' final states.";

// A number, or NaN when s is none (so that every range check fails).
double number(const std::string& s) {
  double v = 0;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() ? v : std::nan("");
}

// The plant of the command line: the robot description (a file or the
// built-in one), and for the lumped plant its parameters (a file, the lumped
// truth of a given robot, or the default lumped parameters).
void configure_plant(const std::string& plant, const std::string& robot_path,
                     const std::string& truth_path, emu::EmulatorConfig& config) {
  if (!robot_path.empty()) config.robot = delta::read_robot_description(robot_path);
  config.geometry = config.robot.geometry;
  // The drives turn the motors by the robot's gear ratios (the controller
  // takes them from the same file: robot = FILE).
  for (unsigned j = 0; j < 3; ++j) config.drives[j].gear_ratio = config.robot.joints[j].gear_ratio;
  if (plant == "mujoco") {
    if (!truth_path.empty()) throw CLI::ValidationError("--truth", "only with --plant lumped");
    config.plant = emu::PlantKind::kMujoco;
    return;
  }
  config.plant = emu::PlantKind::kLumped;
  if (!truth_path.empty()) {
    config.truth = delta::read_lumped_parameters(truth_path);
  } else if (!robot_path.empty()) {
    config.truth = delta::lumped_truth(config.robot);
  }  // else the default lumped parameters (within 0.2 % of the default robot's)
}

// CLI::Range and CLI::NonNegativeNumber let NaN through: these compare so
// that it fails.
const CLI::Validator kInitialAngle(
    [](std::string& s) {
      const double q = number(s);
      return q >= -1.5 && q <= 1.5 ? std::string() : "must be in [-1.5, 1.5]";
    },
    "[-1.5, 1.5]");
const CLI::Validator kCurrentNoise(
    [](std::string& s) {
      const double a = number(s);
      return a >= 0 && a < 1e3 ? std::string() : "must be from 0 to 1000";
    },
    ">= 0");

// The command line's values that are not the configuration's own.
struct EmulatorArguments {
  std::string plant{"mujoco"};
  std::string robot_path;
  std::string truth_path;
  CLI::Option* truth{nullptr};
  std::vector<std::string> faults;
  double initial_q{0.0};
  CLI::Option* initial{nullptr};
  std::string eds_path;
  std::string torque_unit{"per_mille"};
  std::vector<std::string> sets;  // --set jointN.KEY=VALUE
  std::string config_path;        // --config: the controller's configuration
  CLI::Option* approach_given{nullptr};
  CLI::Option* stop_given{nullptr};
};

void add_options(CLI::App& app, std::string& iface, emu::EmulatorConfig& config,
                 EmulatorArguments& a) {
  app.set_version_flag("--version", std::string("delta_drive_emu ") + DELTA_VERSION);
  app.add_option("--can", iface, "the CAN interface (vcan0)")->required();
  app.add_option("--plant", a.plant,
                 "the robot: mujoco (the multibody robot of --robot) or lumped (the lumped "
                 "model: exactly what `host_id fit --model lumped` estimates)")
      ->check(CLI::IsMember({"mujoco", "lumped"}))
      ->capture_default_str();
  app.add_option("--robot", a.robot_path,
                 "the robot description (docs/robot-description.md); default: the built-in "
                 "robot of docs/examples/robot.json");
  a.truth = app.add_option(
      "--truth", a.truth_path,
      "with --plant lumped: the lumped parameters, JSON as `host_id "
      "simulate --params` reads (default: those of --robot, or the default robot's)");
  app.add_option("--inject", a.faults,
                 "KIND[:NODE[:MS]]@SECONDS of simulated time after the first SYNC: "
                 "heartbeat-drop:N, silent:N, error-frame, corrupt-pdo:N, delay-pdo:N:MS, "
                 "overcurrent:N, contact:FORCE_N:DX,DY,DZ:MS (a force on the platform, "
                 "--plant mujoco; prints `contact: t_s=T force_N=F` when it starts) "
                 "(repeatable)")
      ->allow_extra_args(false);
  a.initial_q = config.initial_q_rad[0];
  a.initial = app.add_option("--initial-q", a.initial_q, "the three joints' angle at start, rad")
                  ->check(kInitialAngle);
  app.add_option("--current-noise", config.current_noise_A, "current noise, A (standard deviation)")
      ->check(kCurrentNoise)
      ->capture_default_str();
  app.add_option("--seed", config.seed, "noise seed")->capture_default_str();
  app.add_option("--set", a.sets,
                 "jointN.KEY=VALUE: a value the drive was commissioned with, as the controller's "
                 "key names it (rated_torque_Nm, rated_current_A, counts_per_rev, gear_ratio, "
                 "gearbox_efficiency, inverted, zero_rad, torque_unit); it takes the place of "
                 "the EDS's default (repeatable)");
  app.add_option("--config", a.config_path,
                 "the controller's configuration file (delta_fw --config): its jointN drive "
                 "values, as --set, and its robot = FILE, as --robot; its other keys are the "
                 "controller's")
      ->check(CLI::ExistingFile);
  a.approach_given =
      app.add_option("--approach-s", config.approach_s,
                     "the controller's approach_s: the `arm tracking` line after each run covers "
                     "the span of delta_fw's `tracking` line, after the approach")
          ->check(CLI::PositiveNumber)
          ->capture_default_str();
  a.stop_given =
      app.add_option("--stop-s", config.stop_s,
                     "the controller's stop_s: the `arm tracking` line leaves out the stop")
          ->check(CLI::PositiveNumber)
          ->capture_default_str();
  app.add_option("--eds", a.eds_path,
                 "the drives' EDS or DCF (CiA 306): the drives then behave as it describes, "
                 "with exactly its objects, access types, sizes, defaults (transmission types "
                 "and mappings included) and supported modes (0x6502); without it, the drive of "
                 "docs/eds/delta_drive_emu.eds (docs/drives.md)");
  app.add_option("--torque-unit", a.torque_unit,
                 "the unit of target torque (0x6071) and torque actual value (0x6077), as the "
                 "drive of --eds has it")
      ->check(CLI::IsMember({"per_mille", "mA", "mNm"}))
      ->capture_default_str();
}

// The parsed arguments into config and eds; throws on a file or a fault
// spec that cannot be read.
void apply_arguments(const EmulatorArguments& a, emu::EmulatorConfig& config,
                     std::optional<delta::canopen::Eds>& eds, emu::CommissionedDrives& drives) {
  if (!a.config_path.empty()) drives.read_config(a.config_path);
  // The controller's robot = FILE is the emulated robot, unless --robot
  // says otherwise (the same file, or an error).
  std::string robot_path = a.robot_path;
  if (drives.robot && !robot_path.empty() && *drives.robot != robot_path) {
    throw std::invalid_argument("--robot " + robot_path + " and " + a.config_path +
                                "'s robot = " + *drives.robot + " differ: which robot is it?");
  }
  if (drives.robot) robot_path = *drives.robot;
  // The file's span, unless the options give one.
  if (drives.approach_s && !a.approach_given->count()) config.approach_s = *drives.approach_s;
  if (drives.stop_s && !a.stop_given->count()) config.stop_s = *drives.stop_s;
  for (const std::string& s : a.sets) {
    if (!drives.set(s, "--set")) {
      throw std::invalid_argument("--set " + s +
                                  ": not a drive's value (jointN.rated_torque_Nm, "
                                  "rated_current_A, counts_per_rev, gear_ratio, "
                                  "gearbox_efficiency, inverted, zero_rad, torque_unit)");
    }
  }
  if (!a.eds_path.empty()) {
    eds = delta::canopen::read_eds(a.eds_path);
  }
  if (a.initial->count()) config.initial_q_rad = {a.initial_q, a.initial_q, a.initial_q};
  config.torque_unit = a.torque_unit == "mA"    ? emu::TorqueUnit::kMilliamp
                       : a.torque_unit == "mNm" ? emu::TorqueUnit::kMilliNewtonMetre
                                                : emu::TorqueUnit::kPerMille;
  configure_plant(a.plant, robot_path, a.truth->count() ? a.truth_path : std::string(), config);
  for (const std::string& f : a.faults) config.faults.push_back(emu::parse_fault(f));
  config.report = [](const std::string& line) { std::cout << line << std::endl; };
}

// The command line into config, or the exit code when it asked for help or
// was wrong.
std::optional<int> parse_arguments(int argc, char** argv, std::string& iface,
                                   emu::EmulatorConfig& config,
                                   std::optional<delta::canopen::Eds>& eds,
                                   emu::CommissionedDrives& drives) {
  CLI::App app(kDescription, "delta_drive_emu");
  EmulatorArguments a;
  add_options(app, iface, config, a);
  try {
    app.parse(argc, argv);
    apply_arguments(a, config, eds, drives);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::cerr << "delta_drive_emu: " << e.what() << " (see delta_drive_emu --help)\n";
    return 2;
  } catch (const std::exception& e) {  // a parameter file or a fault spec
    std::cerr << "delta_drive_emu: " << e.what() << "\n";
    return 2;
  }
  return std::nullopt;
}

// The drives' frames on the bus: the emulator fed with what arrives,
// delayed frames sent when due, until SIGINT or SIGTERM. Returns the exit
// status.
int serve(delta::can::Socket& socket, emu::Emulator& emulator,
          std::multimap<std::uint64_t, delta::can::Frame>& delayed, std::uint64_t& send_failures) {
  std::string reported_error;
  while (!g_stop.load()) {
    std::uint64_t now = monotonic_us();
    int timeout_ms = 10;
    if (!delayed.empty()) {
      const std::uint64_t due = delayed.begin()->first;
      timeout_ms =
          due <= now ? 0 : static_cast<int>(std::min<std::uint64_t>(10, (due - now + 999) / 1000));
    }
    pollfd pfd{socket.fd(), POLLIN, 0};
    poll(&pfd, 1, timeout_ms);
    // Frames first, each stamped with the time it is read, then the
    // clocks' checks: a heartbeat that waited in the socket while this
    // process was not scheduled still counts.
    emu::pump_frames(
        emulator, [&socket] { return socket.receive(); }, monotonic_us, kFramesPerPass);
    while (!delayed.empty() && delayed.begin()->first <= monotonic_us()) {
      if (socket.send(delayed.begin()->second) != delta::can::SendResult::kOk) ++send_failures;
      delayed.erase(delayed.begin());
    }
    if (!emulator.plant_error().empty() && reported_error.empty()) {
      reported_error = emulator.plant_error();
      std::cerr << "delta_drive_emu: " << reported_error << "\n";
    }
  }
  std::cerr << "delta_drive_emu: stopped after " << emulator.syncs() << " SYNCs, "
            << emulator.simulated_s() << " s simulated, the longest wait between SYNCs "
            << emulator.longest_sync_gap_s() << " s; send failures " << send_failures << "\n"
            << emulator.describe();
  return reported_error.empty() ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  std::string iface;
  emu::EmulatorConfig config;
  std::optional<delta::canopen::Eds> eds;
  emu::CommissionedDrives drives;
  if (const auto exit_code = parse_arguments(argc, argv, iface, config, eds, drives)) {
    return *exit_code;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    // What the controller sends to drives: NMT, SYNC, RPDO1 and SDO requests;
    // and the heartbeats their consumers (0x1016) watch.
    namespace p = delta::can::protocol;
    delta::can::Socket socket =
        delta::can::Socket::open(iface,
                                 {{p::kNmt.base_id, p::kStandardIdMask, false},
                                  {p::kSync.base_id, p::kStandardIdMask, false},
                                  {p::kRpdo1.base_id, p::kFunctionCodeMask, false},
                                  {p::kSdoRx.base_id, p::kFunctionCodeMask, false},
                                  {p::kHeartbeat.base_id, p::kFunctionCodeMask, false}},
                                 1 << 20);
    // Frames due later (delay-pdo), by wall time.
    std::multimap<std::uint64_t, delta::can::Frame> delayed;
    std::uint64_t send_failures = 0;
    emu::Emulator emulator(config, [&](const delta::can::Frame& f, std::uint32_t delay_us) {
      if (delay_us != 0) {
        delayed.emplace(monotonic_us() + delay_us, f);
      } else if (socket.send(f) != delta::can::SendResult::kOk) {
        ++send_failures;
      }
    });
    if (eds) {
      const std::size_t emulated = emulator.use_eds(*eds);
      std::cout << "delta_drive_emu: the drives of " << eds->path << ": " << eds->variables.size()
                << " objects, " << emulated
                << " with an emulated behaviour, the others keep their values" << std::endl;
      for (const std::string& note : eds->notes) std::cerr << "delta_drive_emu: " << note << "\n";
    }
    emulator.commission(drives);
    if (!drives.taken.empty()) {
      std::cout << "delta_drive_emu: the drives as commissioned:";
      for (const std::string& t : drives.taken) std::cout << " " << t;
      std::cout << std::endl;
    }
    emulator.on_wall_time(monotonic_us());
    emulator.boot();
    std::cout << "delta_drive_emu: ready on " << iface << std::endl;
    return serve(socket, emulator, delayed, send_failures);
  } catch (const delta::can::CanError& e) {
    std::cerr << "delta_drive_emu: " << e.what() << "\n";
    return 1;
  }
}
