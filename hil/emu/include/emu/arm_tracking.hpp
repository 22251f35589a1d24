// The arms' own tracking error, which only the emulator knows (the
// controller sees the motors' encoders; docs/hil.md): per joint, the arm's
// reference (0x607A of each RPDO, the controller's trajectory angle) less
// the arm's angle behind the gearbox at the SYNC that RPDO answers, over
// the span of the controller's `tracking` line: from approach_ticks after
// the drive was enabled to stop_ticks before it was disabled again.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <optional>
#include <string>

namespace emu {

class ArmTracking {
 public:
  ArmTracking(std::uint32_t approach_ticks, std::uint32_t stop_ticks)
      : approach_ticks_(approach_ticks), stop_ticks_(stop_ticks) {}

  // Joint j's error in one cycle its drive is enabled.
  void add(unsigned j, double error_rad);
  // Joint j's drive is no longer enabled: its run ended. Once all three
  // ended, the run's line `arm tracking: rms_rad=a,b,c max_rad=a,b,c`
  // (nothing for a run without samples in its span).
  std::optional<std::string> end(unsigned j);
  bool running(unsigned j) const { return joints_[j].running; }

 private:
  struct Joint {
    bool running{false};
    bool ended{false};
    std::uint32_t cycles{0};     // enabled cycles this run
    std::deque<double> pending;  // the last stop_ticks errors: the stop's, if it ends now
    double sum_sq_rad2{0.0};
    double max_abs_rad{0.0};
    std::uint64_t samples{0};
  };
  std::uint32_t approach_ticks_;
  std::uint32_t stop_ticks_;
  std::array<Joint, 3> joints_{};
};

}  // namespace emu
