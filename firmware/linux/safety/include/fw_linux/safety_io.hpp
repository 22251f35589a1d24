// The safety lines behind a narrow interface: the e-stop input and the
// drive-enable, brake-release and status outputs. The GPIO backend
// (libgpiod) and the simulated backend (tests, the emulator runs) implement
// it.
#pragma once

#include <atomic>

#include "fw/hardware.hpp"

namespace fw_linux {

class SafetyIo {
 public:
  virtual ~SafetyIo() = default;
  // The debounced e-stop input: true when the e-stop circuit is open.
  virtual bool estop_open() = 0;
  virtual void set_outputs(const fw::SafetyOutputs& outputs) = 0;
};

// No hardware: the e-stop is closed unless a test opens it.
class SimulatedSafetyIo : public SafetyIo {
 public:
  bool estop_open() override { return estop_open_.load(); }
  void set_outputs(const fw::SafetyOutputs& outputs) override { outputs_ = outputs; }
  void open_estop(bool open) { estop_open_.store(open); }
  const fw::SafetyOutputs& outputs() const { return outputs_; }

 private:
  std::atomic<bool> estop_open_{false};
  fw::SafetyOutputs outputs_{};
};

}  // namespace fw_linux
