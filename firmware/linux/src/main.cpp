// delta_fw: the firmware's Linux port (docs/firmware.md, docs/hil.md).
#include <algorithm>
#include <atomic>
#include <csignal>
#include <iostream>
#include <memory>
#include <string>

#include "delta/can/socketcan.hpp"
#include "fw_linux/config.hpp"
#include "fw_linux/gpio_safety_io.hpp"
#include "fw_linux/modbus_server.hpp"
#include "fw_linux/port.hpp"
#include "fw_linux/trajectories.hpp"

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) {
  g_stop.store(true);
}

constexpr const char* kUsage =
    "usage: delta_fw --can IFACE [--config FILE] [--set KEY=VALUE]... [--lockstep|--realtime]\n"
    "                [--run TRAJECTORY]... [--exit-when-done] [--max-cycles N] [--rt-priority P]\n"
    "\n"
    "Runs the controller on a SocketCAN interface with three CiA 402 drives (nodes 1-3).\n"
    "  --config FILE      key = value settings (docs/firmware.md); --set overrides one\n"
    "  --lockstep         the next cycle starts when the drives answered (for the emulator)\n"
    "  --realtime         a cycle every period_us (the default)\n"
    "  --run NAME         run a trajectory once ready: path1, path2, pick-and-place\n"
    "  --exit-when-done   exit after the last --run (0), or on a fault (3)\n"
    "Modbus (docs/modbus.md): --set modbus.tcp=ADDRESS:PORT and/or --set modbus.rtu_device=DEV.\n"
    "Safety lines: --set gpio.chip=gpiochip0 (libgpiod); without it they are simulated.\n"
    "On SIGINT or SIGTERM it disables the drives and exits.\n"
    "Exit codes: 0 done, 1 CAN error, 2 usage or configuration error, 3 fault, 4 rejected,\n"
    "5 stopped by a signal before the runs finished, 6 Modbus or GPIO could not start.\n";

int usage_error(const std::string& message) {
  std::cerr << "delta_fw: " << message << "\n" << kUsage;
  return fw_linux::kExitUsage;
}

}  // namespace

int main(int argc, char** argv) {
  fw_linux::RunOptions options;
  std::string config_path;
  std::vector<std::pair<std::string, std::string>> overrides;
  int mode = 0;  // 1 lock-step, 2 real time
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char* what) -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs " + what);
      return argv[++i];
    };
    try {
      if (a == "--help" || a == "-h") {
        std::cout << kUsage;
        return 0;
      } else if (a == "--can") {
        options.iface = value("an interface name");
      } else if (a == "--config") {
        config_path = value("a file");
      } else if (a == "--set") {
        const std::string kv = value("KEY=VALUE");
        const auto eq = kv.find('=');
        if (eq == std::string::npos) return usage_error("--set needs KEY=VALUE, got '" + kv + "'");
        overrides.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
      } else if (a == "--lockstep") {
        mode = 1;
      } else if (a == "--realtime") {
        mode = 2;
      } else if (a == "--run") {
        options.trajectories.push_back(value("a trajectory name"));
      } else if (a == "--exit-when-done") {
        options.exit_when_done = true;
      } else if (a == "--max-cycles") {
        options.max_cycles = std::stoull(value("a number"));
      } else if (a == "--rt-priority") {
        options.rt_priority = std::stoi(value("a priority (1-99)"));
      } else {
        return usage_error("unknown option '" + a + "'");
      }
    } catch (const std::invalid_argument& e) {
      return usage_error(e.what());
    } catch (const std::out_of_range& e) {
      return usage_error(a + ": number out of range");
    }
  }
  if (options.iface.empty()) return usage_error("--can IFACE is required");

  fw_linux::PortConfig config;
  try {
    if (!config_path.empty()) config = fw_linux::read_port_config(config_path);
    for (const auto& [key, v] : overrides) {
      fw_linux::set_config_value(config, key, v, "--set " + key);
    }
    if (mode == 1) config.mode = fw_linux::CycleMode::kLockStep;
    if (mode == 2) config.mode = fw_linux::CycleMode::kRealTime;
    fw_linux::validate(config);
    (void)fw_linux::controller_config(config);
  } catch (const fw_linux::ConfigError& e) {
    std::cerr << "delta_fw: " << e.what() << "\n";
    return fw_linux::kExitUsage;
  }

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  std::signal(SIGPIPE, SIG_IGN);  // a Modbus client that vanishes mid-reply
  try {
    std::unique_ptr<fw_linux::SafetyIo> io;
    if (config.gpio.chip.empty()) {
      io = std::make_unique<fw_linux::SimulatedSafetyIo>();
    } else {
      io = std::make_unique<fw_linux::GpioSafetyIo>(config.gpio);
      std::cerr << "delta_fw: safety lines on " << config.gpio.chip << "\n";
    }
    fw_linux::ControlPanel panel;
    std::unique_ptr<fw_linux::ModbusServer> modbus;
    if (!config.modbus.tcp.empty() || !config.modbus.rtu_device.empty()) {
      modbus = std::make_unique<fw_linux::ModbusServer>(config, panel);
      options.panel = &panel;
      if (modbus->tcp_port() != 0) {
        std::cerr << "delta_fw: Modbus TCP on "
                  << fw_linux::split_host_port(config.modbus.tcp, "modbus.tcp").first << ":"
                  << modbus->tcp_port() << "\n";
      }
      if (!config.modbus.rtu_device.empty()) {
        std::cerr << "delta_fw: Modbus RTU on " << config.modbus.rtu_device << ", unit "
                  << config.modbus.rtu_unit_id << "\n";
      }
    }
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
