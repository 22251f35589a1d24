// The Cortex-M image whose control steps tests/bench/m4_cycle_estimate.py
// prices one by one from qemu's trace of the blocks it executes: for each
// path of step_bench.hpp, 200 running steps between step_window_begin and
// step_window_end, with step_done after each. The path names go to the
// semihosting output in the same order.
#include <cstdint>

#include "semihosting.hpp"
#include "step_bench.hpp"

extern "C" int firmware_main();

namespace {

// Under their own names, and not inlined, so that the trace shows them.
__attribute__((noinline)) void step_window_begin() {
  asm volatile("" ::: "memory");
}
__attribute__((noinline)) void step_window_end() {
  asm volatile("" ::: "memory");
}
__attribute__((noinline)) void step_done() {
  asm volatile("" ::: "memory");
}

}  // namespace

extern "C" int firmware_main() {
  constexpr std::uint32_t kSteps = 200;
  bool all_done = true;
  for (const auto& path : fw::bench::kStepPaths) {
    semihosting::write(path.name);
    semihosting::write("\n");
    all_done =
        all_done && fw::bench::run_control_steps(
                        path, kSteps, {step_window_begin, step_window_end, step_done}) == kSteps;
  }
  return all_done ? 0 : 1;
}
