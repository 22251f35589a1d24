// delta_drive_emu: three emulated CiA 402 drives and the robot they move, on
// a SocketCAN interface (docs/hil.md).
#include <poll.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <csignal>
#include <iostream>
#include <map>
#include <string>

#include "delta/can/protocol.hpp"
#include "delta/can/socketcan.hpp"
#include "delta/input_error.hpp"
#include "delta/parameter_file.hpp"
#include "emu/emulator.hpp"

namespace {

std::atomic<bool> g_stop{false};
void on_signal(int) {
  g_stop.store(true);
}

std::uint64_t monotonic_us() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1000000u +
         static_cast<std::uint64_t>(ts.tv_nsec) / 1000u;
}

constexpr const char* kUsage =
    "usage: delta_drive_emu --can IFACE [--plant lumped] [--truth FILE] [--inject FAULT]...\n"
    "                       [--initial-q RAD] [--current-noise A] [--seed N]\n"
    "\n"
    "Emulates three CiA 402 drives (nodes 1-3) and the default delta robot they move.\n"
    "  --truth FILE     the plant's parameters, JSON as `host_id simulate --params` reads\n"
    "  --inject FAULT   KIND[:NODE[:MS]]@SECONDS of simulated time after the first SYNC:\n"
    "                   heartbeat-drop:N, silent:N, error-frame, corrupt-pdo:N,\n"
    "                   delay-pdo:N:MS, overcurrent:N\n"
    "Prints 'delta_drive_emu: ready on IFACE' on stdout once listening; stops on SIGINT or\n"
    "SIGTERM and prints the drives' final states.\n";

int usage_error(const std::string& m) {
  std::cerr << "delta_drive_emu: " << m << "\n" << kUsage;
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::string iface;
  emu::EmulatorConfig config;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(a + " needs a value");
      return argv[++i];
    };
    try {
      if (a == "--help" || a == "-h") {
        std::cout << kUsage;
        return 0;
      } else if (a == "--can") {
        iface = value();
      } else if (a == "--plant") {
        const std::string plant = value();
        if (plant != "lumped")
          return usage_error("--plant: only 'lumped' exists, got '" + plant + "'");
      } else if (a == "--truth") {
        config.truth = delta::read_lumped_parameters(value());
      } else if (a == "--inject") {
        config.faults.push_back(emu::parse_fault(value()));
      } else if (a == "--initial-q") {
        const double q = std::stod(value());
        config.initial_q_rad = {q, q, q};
      } else if (a == "--current-noise") {
        config.current_noise_A = std::stod(value());
        if (!(config.current_noise_A >= 0)) return usage_error("--current-noise must be >= 0");
      } else if (a == "--seed") {
        config.seed = std::stoull(value());
      } else {
        return usage_error("unknown option '" + a + "'");
      }
    } catch (const delta::InputError& e) {
      std::cerr << "delta_drive_emu: " << e.what() << "\n";
      return 2;
    } catch (const std::exception& e) {
      return usage_error(a + ": " + e.what());
    }
  }
  if (iface.empty()) return usage_error("--can IFACE is required");

  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  try {
    // What the controller sends to drives: NMT, SYNC, RPDO1 and SDO requests.
    namespace p = delta::can::protocol;
    delta::can::Socket socket = delta::can::Socket::open(iface,
                                                         {{p::kNmt.base_id, 0x7FF, false},
                                                          {p::kSync.base_id, 0x7FF, false},
                                                          {p::kRpdo1.base_id, 0x780, false},
                                                          {p::kSdoRx.base_id, 0x780, false}},
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
    emulator.on_wall_time(monotonic_us());
    emulator.boot();
    std::cout << "delta_drive_emu: ready on " << iface << std::endl;
    std::string reported_error;
    while (!g_stop.load()) {
      std::uint64_t now = monotonic_us();
      int timeout_ms = 10;
      if (!delayed.empty()) {
        const std::uint64_t due = delayed.begin()->first;
        timeout_ms = due <= now
                         ? 0
                         : static_cast<int>(std::min<std::uint64_t>(10, (due - now + 999) / 1000));
      }
      pollfd pfd{socket.fd(), POLLIN, 0};
      poll(&pfd, 1, timeout_ms);
      now = monotonic_us();
      emulator.on_wall_time(now);
      while (auto r = socket.receive()) {
        if (!r->error) emulator.on_frame(r->frame);
      }
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
              << emulator.simulated_s() << " s simulated; send failures " << send_failures << "\n"
              << emulator.describe();
    return reported_error.empty() ? 0 : 3;
  } catch (const delta::can::CanError& e) {
    std::cerr << "delta_drive_emu: " << e.what() << "\n";
    return 1;
  }
}
