// The control step under measurement: Controller::step() running a
// trajectory, the feed-forward, joint control and torque from current,
// against a hardware stand-in whose joints follow the reference. Shared by
// the host benchmark (callgrind), the Cortex-M image that counts
// instructions on qemu, and the image whose every step the budget test
// prices (tests/bench/m4_cycle_estimate.py).
#pragma once

#include <cstdint>

#include "fw/feed_forward.hpp"

namespace fw::bench {

// The two kinds of trajectory the controller runs:
// - pick-and-place: one IK per tick (the other two of the window are kept),
//   the platform's position and acceleration from the Cartesian path;
// - Fourier excitation (joint space, 5 harmonics of 0.2 Hz, host_id's
//   default), measured from its start, inside the fade-in: the model solves
//   the forward kinematics and J'q' at every tick.
enum class StepTrajectory { kPickAndPlace, kFourier };

// One path through the step: a trajectory and a feed-forward. The budget
// holds for each of them (docs/firmware.md, "Speed").
struct StepPath {
  const char* name;
  StepTrajectory trajectory;
  FeedForwardMode feed_forward;
};

// Every path, in the order the images measure them. The model's
// feed-forward has every term on (the Stribeck term too): its most
// expensive configuration.
inline constexpr StepPath kStepPaths[] = {
    {"pick_and_place_nominal", StepTrajectory::kPickAndPlace, FeedForwardMode::kNominal},
    {"pick_and_place_model", StepTrajectory::kPickAndPlace, FeedForwardMode::kModel},
    {"fourier_nominal", StepTrajectory::kFourier, FeedForwardMode::kNominal},
    {"fourier_model", StepTrajectory::kFourier, FeedForwardMode::kModel},
};

// Called around the measured steps: begin() before the first, end() after
// the last, and after_step() after each (nullptr: not called).
struct StepMarks {
  void (*begin)();
  void (*end)();
  void (*after_step)();
};

// Sets up a controller, brings it to running and returns the number of
// running steps done (n on success). Only the n measured steps run between
// marks.begin() and marks.end().
std::uint32_t run_control_steps(const StepPath& path, std::uint32_t n, const StepMarks& marks);

// The controller's state and fault after the last run (for messages).
extern int last_state;
extern int last_fault;

}  // namespace fw::bench
