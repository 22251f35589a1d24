// Golden vectors: fixed inputs and the exact integer outputs of the fixed-
// point math, kinematics, trajectories, torque conversion and joint control.
// The host build and the Cortex-M image (on qemu) both print them; the two
// outputs and tests/data/golden_vectors.txt must agree byte for byte.
// Integer-only code: no heap, no floating point, no stdio.
#pragma once

#include <cstdint>

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

}  // namespace fw::golden
