// Runs the measured control steps on the host, for
//   valgrind --tool=callgrind --toggle-collect='*measured_control_steps*' step_host N PATH
// (tests/bench/count_step_instructions.sh divides by the step count), PATH
// one of step_bench.hpp's paths (default pick_and_place_model).
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "step_bench.hpp"

int main(int argc, char** argv) {
  const auto n = static_cast<std::uint32_t>(argc > 1 ? std::strtoul(argv[1], nullptr, 10) : 1000);
  if (n == 0) {
    std::fprintf(stderr, "step_host: the step count '%s' is not a whole number above 0\n", argv[1]);
    return 2;
  }
  const char* name = argc > 2 ? argv[2] : "pick_and_place_model";
  const fw::bench::StepPath* path = nullptr;
  for (const auto& p : fw::bench::kStepPaths) {
    if (std::strcmp(p.name, name) == 0) path = &p;
  }
  if (path == nullptr) {
    std::fprintf(stderr, "step_host: unknown path '%s': use one of", name);
    for (const auto& p : fw::bench::kStepPaths) std::fprintf(stderr, " %s", p.name);
    std::fprintf(stderr, "\n");
    return 2;
  }
  const std::uint32_t done = fw::bench::run_control_steps(*path, n, {[] {}, [] {}, nullptr});
  std::printf("%u control steps of %s (state %d, fault %d)\n", done, path->name,
              fw::bench::last_state, fw::bench::last_fault);
  return done == n ? 0 : 1;
}
