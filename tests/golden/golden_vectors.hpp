// Golden vectors: fixed inputs and the exact integer outputs of the fixed-
// point math, kinematics, trajectories, torque conversion and joint control.
// The host build and the Cortex-M image (on qemu) both print them; the two
// outputs and tests/data/golden_vectors.txt must agree byte for byte.
// Integer-only code: no heap, no floating point, no stdio.
#pragma once

#include <cstdint>

#include "delta/fixed/dynamics.hpp"

namespace fw::golden {

// Receives the text, piece by piece.
class TextSink {
 public:
  virtual void write(const char* text) = 0;

 protected:
  ~TextSink() = default;
};

// Writes every vector; returns the number of lines written.
std::uint32_t write_golden_vectors(TextSink& out);

// The identified model the vectors (and the step benchmark) run: every term
// present, joints that differ, about the default robot's values.
delta::fx::ModelParametersQ example_model_parameters();

}  // namespace fw::golden
