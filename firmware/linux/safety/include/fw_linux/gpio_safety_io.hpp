// The safety lines on a GPIO chip, through libgpiod 1.6 (its v1 API, as
// Debian bookworm ships it):
//   e-stop        input, active-low (a low line is an open e-stop circuit),
//                 debounced by EStopDebouncer
//   drive enable  output, high = enabled
//   brake release output, high = released; de-energised (low) = braked
//   status        output, high = no fault
// Every output starts low and goes low again when the backend is destroyed.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

#include "fw_linux/config.hpp"
#include "fw_linux/safety_io.hpp"

struct gpiod_chip;
struct gpiod_line;

namespace fw_linux {

// A configured chip or line is missing or busy; the message names it.
class GpioError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The e-stop's debouncing, fail-safe: an open reading counts at once (the
// drives go off in the same cycle); a closed one only once the line has read
// closed for `closed_for_us` without a break. The first reading counts as is.
class EStopDebouncer {
 public:
  explicit EStopDebouncer(std::uint64_t closed_for_us) : closed_for_us_(closed_for_us) {}
  bool update(bool raw_open, std::uint64_t now_us);
  bool open() const { return open_; }

 private:
  std::uint64_t closed_for_us_;
  bool first_{true};
  bool open_{true};
  bool last_raw_open_{true};
  std::uint64_t closed_since_us_{0};
};

class GpioSafetyIo : public SafetyIo {
 public:
  // Opens the chip and requests the four lines; throws GpioError.
  explicit GpioSafetyIo(const GpioConfig& config);
  ~GpioSafetyIo() override;
  GpioSafetyIo(const GpioSafetyIo&) = delete;
  GpioSafetyIo& operator=(const GpioSafetyIo&) = delete;

  bool estop_open() override;
  void set_outputs(const fw::SafetyOutputs& outputs) override;
  // Reads or writes that failed (a failed read counts as an open e-stop).
  std::uint64_t io_errors() const { return io_errors_; }

 private:
  gpiod_line* request(std::uint32_t offset, const char* key, bool output);

  GpioConfig config_;
  gpiod_chip* chip_{nullptr};
  gpiod_line* estop_{nullptr};
  gpiod_line* enable_{nullptr};
  gpiod_line* brake_{nullptr};
  gpiod_line* status_{nullptr};
  EStopDebouncer debouncer_;
  std::uint64_t io_errors_{0};
};

}  // namespace fw_linux
