#include "emu/arm_tracking.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace emu {

void ArmTracking::add(unsigned j, double error_rad) {
  Joint& t = joints_[j];
  if (!t.running) {
    t = Joint{};
    t.running = true;
  }
  if (t.cycles++ < approach_ticks_) return;
  t.pending.push_back(error_rad);
  if (t.pending.size() <= stop_ticks_) return;
  const double e = t.pending.front();
  t.pending.pop_front();
  t.sum_sq_rad2 += e * e;
  t.max_abs_rad = std::max(t.max_abs_rad, std::abs(e));
  ++t.samples;
}

std::optional<std::string> ArmTracking::end(unsigned j) {
  if (!joints_[j].running) return std::nullopt;
  joints_[j].running = false;
  joints_[j].ended = true;
  for (const Joint& t : joints_) {
    if (t.running) return std::nullopt;
  }
  std::array<double, 3> rms{};
  std::array<double, 3> max{};
  bool any = false;
  for (unsigned k = 0; k < 3; ++k) {
    Joint& t = joints_[k];
    if (t.ended && t.samples > 0) {
      rms[k] = std::sqrt(t.sum_sq_rad2 / static_cast<double>(t.samples));
      max[k] = t.max_abs_rad;
      any = true;
    }
    t = Joint{};
  }
  if (!any) return std::nullopt;
  char line[160];
  std::snprintf(line, sizeof line, "arm tracking: rms_rad=%.6g,%.6g,%.6g max_rad=%.6g,%.6g,%.6g",
                rms[0], rms[1], rms[2], max[0], max[1], max[2]);
  return std::string(line);
}

}  // namespace emu
