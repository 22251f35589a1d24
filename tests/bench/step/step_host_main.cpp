// Runs the measured control steps on the host, for
//   valgrind --tool=callgrind --toggle-collect='*measured_control_steps*' step_host [N]
//   [pick_and_place|fourier]
// (tests/bench/count_step_instructions.sh divides by the step count):
// pick-and-place, or with `fourier` the Fourier excitation.
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
  const bool fourier = argc > 2 && std::strcmp(argv[2], "fourier") == 0;
  if (argc > 2 && !fourier && std::strcmp(argv[2], "pick_and_place") != 0) {
    std::fprintf(stderr, "step_host: unknown trajectory '%s': use pick_and_place or fourier\n",
                 argv[2]);
    return 2;
  }
  const std::uint32_t done = fw::bench::run_control_steps(
      fourier ? fw::bench::StepTrajectory::kFourier : fw::bench::StepTrajectory::kPickAndPlace, n,
      [] {}, [] {});
  std::printf("%u control steps (state %d, fault %d)\n", done, fw::bench::last_state,
              fw::bench::last_fault);
  return done == n ? 0 : 1;
}
