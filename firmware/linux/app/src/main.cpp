// delta_fw: the firmware's Linux port (docs/firmware.md, docs/hil.md).
#include <CLI/CLI.hpp>
#include <atomic>
#include <csignal>
#include <iostream>
#include <memory>
#include <optional>
#include <string>

#include "delta/can/socketcan.hpp"
#include "fw_linux/bus_load.hpp"
#include "fw_linux/config.hpp"
#include "fw_linux/drive_plan.hpp"
#include "fw_linux/exit_codes.hpp"
#include "fw_linux/gpio_safety_io.hpp"
#include "fw_linux/modbus_server.hpp"
#include "fw_linux/port.hpp"
#include "fw_linux/trajectories.hpp"

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) {
  g_stop.store(true);
}

constexpr const char* kDescription =
    "Runs the controller on a SocketCAN interface with three CiA 402 drives (nodes 1-3). "
    "Modbus (docs/modbus.md): --set modbus.tcp=ADDRESS:PORT and/or --set modbus.rtu_device=DEV. "
    "Safety lines: --set gpio.chip=gpiochip0 (libgpiod); without it they are simulated. On "
    "SIGINT or SIGTERM it disables the drives and exits. Exit codes: 0 done, 1 CAN error, 2 "
    "usage or configuration error, 3 fault, 4 rejected, 5 stopped by a signal before the runs "
    "finished, 6 Modbus or GPIO could not start.";

struct Arguments {
  fw_linux::RunOptions run;
  std::string config_path;
  std::vector<std::string> overrides;  // KEY=VALUE
  bool lockstep{false};
  bool realtime{false};
  bool check_config{false};
};

// The command line, or the exit code when it asked for help or was wrong.
std::optional<int> parse_arguments(int argc, char** argv, Arguments& a) {
  CLI::App app(kDescription, "delta_fw");
  app.set_version_flag("--version", std::string("delta_fw ") +
                                        std::to_string(DELTA_FW_VERSION_MAJOR) + "." +
                                        std::to_string(DELTA_FW_VERSION_MINOR) + "." +
                                        std::to_string(DELTA_FW_VERSION_PATCH));
  auto* can = app.add_option("--can", a.run.iface, "the CAN interface (can0, vcan0)");
  auto* check = app.add_flag("--check-config", a.check_config,
                             "check the configuration with every drive's EDS and print each "
                             "drive's bring-up plan (exit 0), or every problem (exit 2); needs no "
                             "CAN interface (docs/drives.md)");
  can->excludes(check);
  app.add_option("--config", a.config_path, "key = value settings (docs/firmware.md)");
  app.add_option("--set", a.overrides, "KEY=VALUE: override one setting (repeatable)")
      ->allow_extra_args(false)
      ->check(CLI::Validator(
          [](std::string& kv) {
            return kv.find('=') == std::string::npos ? "needs KEY=VALUE, got '" + kv + "'"
                                                     : std::string();
          },
          "KEY=VALUE"));
  auto* lockstep =
      app.add_flag("--lockstep", a.lockstep,
                   "the next cycle starts when the drives answered (for the emulator)");
  app.add_flag("--realtime", a.realtime, "a cycle every period_us (the default)")
      ->excludes(lockstep);
  app.add_option("--run", a.run.trajectories,
                 "run a trajectory once ready: path1, path2, pick-and-place; "
                 "NAME:N repeats it N times (Fourier periods, pick-and-place cycles); repeatable")
      ->allow_extra_args(false);
  app.add_flag("--exit-when-done", a.run.exit_when_done,
               "exit after the last --run (0), or on a fault (3)");
  app.add_option("--max-cycles", a.run.max_cycles, "stop after N cycles (0: no limit)");
  app.add_option("--rt-priority", a.run.rt_priority, "SCHED_FIFO priority in real time")
      ->check(CLI::Range(1, 99));
  try {
    app.parse(argc, argv);
    if (!a.check_config && a.run.iface.empty()) {
      throw CLI::RequiredError("--can (or --check-config)");
    }
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    std::cerr << "delta_fw: " << e.what() << " (see delta_fw --help)\n";
    return fw_linux::kExitUsage;
  }
  return std::nullopt;
}

// The file, then --set, then the checks; with `problems`, every problem
// is kept there instead of thrown.
fw_linux::PortConfig load_config(const Arguments& a, std::vector<std::string>* problems) {
  fw_linux::PortConfig config;
  if (!a.config_path.empty()) fw_linux::read_config_lines(config, a.config_path, problems);
  for (const std::string& kv : a.overrides) {
    const auto eq = kv.find('=');
    const std::string key = kv.substr(0, eq);
    try {
      fw_linux::set_config_value(config, key, kv.substr(eq + 1), "--set " + key);
    } catch (const fw_linux::ConfigError& e) {
      if (problems == nullptr) throw;
      problems->emplace_back(e.what());
    }
  }
  if (a.lockstep) config.mode = fw_linux::CycleMode::kLockStep;
  if (a.realtime) config.mode = fw_linux::CycleMode::kRealTime;
  fw_linux::finish_config(config, problems);
  return config;
}

// --check-config: each drive's plan, or every problem.
int check_config(const Arguments& a) {
  std::vector<std::string> problems;
  fw_linux::PortConfig config;
  try {
    config = load_config(a, &problems);
  } catch (const fw_linux::ConfigError& e) {  // a file that cannot be opened
    problems.emplace_back(e.what());
  }
  if (!problems.empty()) {
    std::cerr << "delta_fw --check-config: " << problems.size()
              << (problems.size() == 1 ? " problem" : " problems") << ":\n";
    for (const std::string& p : problems) std::cerr << "  " << p << "\n";
    return fw_linux::kExitUsage;
  }
  const fw_linux::CollisionSetting collision = fw_linux::collision_at_start(config);
  if (!collision.problem.empty()) {
    std::cerr << "delta_fw --check-config: 1 problem:\n  " << collision.problem << "\n";
    return fw_linux::kExitUsage;
  }
  if (config.robot) std::cout << fw_linux::describe_robot(config) << "\n";
  std::cout << fw_linux::describe_feed_forward(config) << "\n";
  std::cout << fw_linux::describe_collision(collision) << "\n";
  const fw_linux::DrivePlans plans = fw_linux::plan_drives(config);
  std::size_t transfers = 0;
  for (const fw_linux::DrivePlan& plan : plans.drives) {
    std::cout << fw_linux::describe_plan(plan);
    transfers += plan.actions.size();
  }
  std::cout << fw_linux::describe_bus_load(config) << "\n";
  if (const auto warning = fw_linux::bus_load_warning(config)) {
    std::cerr << "delta_fw --check-config: warning: " << *warning << "\n";
  }
  std::cout << "The configuration is sound: " << transfers
            << " SDO transfers bring the three drives up.\n";
  return 0;
}

std::unique_ptr<fw_linux::SafetyIo> open_safety_io(const fw_linux::PortConfig& config) {
  if (config.gpio.chip.empty()) return std::make_unique<fw_linux::SimulatedSafetyIo>();
  auto io = std::make_unique<fw_linux::GpioSafetyIo>(config.gpio);
  std::cerr << "delta_fw: safety lines on " << config.gpio.chip << "\n";
  return io;
}

std::unique_ptr<fw_linux::ModbusServer> open_modbus(const fw_linux::PortConfig& config,
                                                    fw_linux::ControlPanel& panel,
                                                    const fw_linux::ProgramFacts& program) {
  if (config.modbus.tcp.empty() && config.modbus.rtu_device.empty()) return nullptr;
  auto modbus = std::make_unique<fw_linux::ModbusServer>(config, panel, program);
  if (modbus->tcp_port() != 0) {
    std::cerr << "delta_fw: Modbus TCP on "
              << fw_linux::split_host_port(config.modbus.tcp, "modbus.tcp").first << ":"
              << modbus->tcp_port() << "\n";
  }
  if (!config.modbus.rtu_device.empty()) {
    std::cerr << "delta_fw: Modbus RTU on " << config.modbus.rtu_device << ", unit "
              << config.modbus.rtu_unit_id << "\n";
  }
  return modbus;
}

int run(const fw_linux::PortConfig& config, fw_linux::RunOptions options) {
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGPIPE, SIG_IGN);  // a Modbus client that vanishes mid-reply
  try {
    if (const auto warning = fw_linux::bus_load_warning(config)) {
      std::cerr << "delta_fw: warning: " << *warning << "\n";
    }
    const auto io = open_safety_io(config);
    fw_linux::ControlPanel panel;
    const auto modbus = open_modbus(config, panel, options.program);
    if (modbus) options.panel = &panel;
    return fw_linux::run_port(config, options, *io, g_stop, std::cerr);
  } catch (const fw_linux::GpioError& e) {
    std::cerr << "delta_fw: " << e.what() << "\n";
    return fw_linux::kExitIo;
  } catch (const fw_linux::ModbusError& e) {
    std::cerr << "delta_fw: " << e.what() << "\n";
    return fw_linux::kExitIo;
  } catch (const delta::can::CanError& e) {
    std::cerr << "delta_fw: " << e.what() << "\n";
    return fw_linux::kExitCanError;
  } catch (const fw_linux::ConfigError& e) {
    std::cerr << "delta_fw: " << e.what() << "\n";
    return fw_linux::kExitUsage;
  }
}

}  // namespace

int main(int argc, char** argv) {
  Arguments arguments;
  if (const auto exit_code = parse_arguments(argc, argv, arguments)) return *exit_code;
  arguments.run.program.version = {DELTA_FW_VERSION_MAJOR, DELTA_FW_VERSION_MINOR,
                                   DELTA_FW_VERSION_PATCH};
  if (arguments.check_config) return check_config(arguments);
  fw_linux::PortConfig config;
  try {
    config = load_config(arguments, nullptr);
    arguments.run.supervision = fw_linux::boot::supervision_from_environment();
    if (arguments.run.supervision) {
      arguments.run.program.rolled_back = arguments.run.supervision->reverted;
    }
  } catch (const fw_linux::ConfigError& e) {
    std::cerr << "delta_fw: " << e.what() << "\n";
    return fw_linux::kExitUsage;
  }
  return run(config, arguments.run);
}
