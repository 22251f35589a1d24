// The control step under measurement: Controller::step() running a
// pick-and-place trajectory (3 IK per tick), the identified model's
// feed-forward, joint control and torque from current, against a hardware stand-in whose joints
// follow the reference. Shared by the host benchmark (callgrind) and the Cortex-M image (qemu).
#pragma once

#include <cstdint>

namespace fw::bench {

// Sets up a controller, brings it to running and returns the number of
// running steps done (n on success). Only the n measured steps run between
// the calls to mark_begin() and mark_end().
std::uint32_t run_control_steps(std::uint32_t n, void (*mark_begin)(), void (*mark_end)());

// The controller's state and fault after the last run (for messages).
extern int last_state;
extern int last_fault;

}  // namespace fw::bench
