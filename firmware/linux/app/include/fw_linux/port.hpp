// The Linux port's main loop: the core's controller on a SocketCAN bus,
// cycle by cycle, in real time (timerfd) or in lock-step with the drives.
#pragma once

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "fw_linux/boot_protocol.hpp"
#include "fw_linux/collision_setting.hpp"
#include "fw_linux/config.hpp"
#include "fw_linux/control_panel.hpp"
#include "fw_linux/exit_codes.hpp"
#include "fw_linux/program_facts.hpp"
#include "fw_linux/safety_io.hpp"

namespace fw_linux {

struct RunOptions {
  std::string iface;
  std::vector<std::string> trajectories;         // run one after the other, from ready
  bool exit_when_done{false};                    // exit after the last one (or a fault)
  std::uint64_t max_cycles{0};                   // 0: no limit
  int rt_priority{0};                            // SCHED_FIFO priority in real time; 0: none
  ControlPanel* panel{nullptr};                  // commands and status for Modbus; may be null
  ProgramFacts program;                          // this program's version (0x1018, 0x100A)
  std::optional<boot::Supervision> supervision;  // from delta_boot; none without it
};

struct CycleStats {
  std::uint64_t cycles{0};
  std::uint64_t overruns{0};       // real time: timer expirations missed
  std::int64_t latency_max_us{0};  // real time: wake-up after the tick
  std::int64_t latency_p99_us{0};
  double latency_mean_us{0};
  std::int64_t step_max_us{0};  // the core's step()
  double wall_s{0};
  double simulated_s{0};
  std::uint64_t late_frames{0};
  std::uint64_t stale_log_records{0};  // logged, marked stale: a drive's feedback missed the cycle
  std::uint64_t send_failures{0};
};

// Runs until `stop` is set, the cycle limit, or (with exit_when_done) the
// end of the trajectories or a fault. Messages go to `out`. Returns an exit
// code above; throws delta::can::CanError when the bus cannot be opened.
// The collision detector as delta_fw starts with it: for the model the
// configuration names, or the one kept in feed_forward.store, which takes
// its place (as at start; --check-config says the same).
CollisionSetting collision_at_start(const PortConfig& config);

int run_port(const PortConfig& config, const RunOptions& options, SafetyIo& io,
             const std::atomic<bool>& stop, std::ostream& out, CycleStats* stats = nullptr);

}  // namespace fw_linux
