// The control step under measurement: Controller::step() running a
// trajectory, the identified model's feed-forward, joint control and torque
// from current, against a hardware stand-in whose joints follow the
// reference. Shared by the host benchmark (callgrind) and the Cortex-M
// image (qemu).
#pragma once

#include <cstdint>

namespace fw::bench {

// The two kinds of trajectory the controller runs:
// - pick-and-place: one IK per tick (the other two of the window are kept),
//   the platform's position and acceleration from the Cartesian path;
// - Fourier excitation (joint space, 5 harmonics of 0.2 Hz, host_id's
//   default), measured from its start, inside the fade-in: the model solves
//   the forward kinematics and J'q' at every tick.
enum class StepTrajectory { kPickAndPlace, kFourier };

// Sets up a controller, brings it to running and returns the number of
// running steps done (n on success). Only the n measured steps run between
// the calls to mark_begin() and mark_end().
std::uint32_t run_control_steps(StepTrajectory kind, std::uint32_t n, void (*mark_begin)(),
                                void (*mark_end)());

// The controller's state and fault after the last run (for messages).
extern int last_state;
extern int last_fault;

}  // namespace fw::bench
