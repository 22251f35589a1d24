#include "fw_linux/gpio_safety_io.hpp"

#include <gpiod.h>

#include <cerrno>
#include <cstring>

#include "delta/monotonic_clock.hpp"

namespace fw_linux {

using delta::monotonic_us;

bool EStopDebouncer::update(bool raw_open, std::uint64_t now_us) {
  if (first_) {
    first_ = false;
    open_ = raw_open;
    last_raw_open_ = raw_open;
    closed_since_us_ = now_us;
    return open_;
  }
  if (raw_open) {
    open_ = true;
  } else if (last_raw_open_) {
    closed_since_us_ = now_us;  // the first closed reading after an open one
  }
  if (!raw_open && open_ && now_us - closed_since_us_ >= closed_for_us_) open_ = false;
  last_raw_open_ = raw_open;
  return open_;
}

GpioSafetyIo::GpioSafetyIo(const GpioConfig& config)
    : config_(config), debouncer_(std::uint64_t{config.estop_debounce_ms} * 1000u) {
  chip_ = gpiod_chip_open_lookup(config.chip.c_str());
  if (chip_ == nullptr) {
    throw GpioError("gpio.chip = " + config.chip + ": cannot open the GPIO chip: " +
                    std::strerror(errno) + " (ls /dev/gpiochip* or gpiodetect lists the chips)");
  }
  try {
    estop_ = request(config.estop_line, "gpio.estop_line", false);
    enable_ = request(config.enable_line, "gpio.enable_line", true);
    brake_ = request(config.brake_line, "gpio.brake_line", true);
    status_ = request(config.status_line, "gpio.status_line", true);
  } catch (...) {
    gpiod_chip_close(chip_);  // releases the lines requested so far
    throw;
  }
}

GpioSafetyIo::~GpioSafetyIo() {
  // Disabled, braked, no status: whatever happened before.
  for (gpiod_line* l : {enable_, brake_, status_}) gpiod_line_set_value(l, 0);
  gpiod_chip_close(chip_);
}

gpiod_line* GpioSafetyIo::request(std::uint32_t offset, const char* key, bool output) {
  const std::string where =
      std::string(key) + " = " + std::to_string(offset) + " on " + gpiod_chip_name(chip_);
  if (offset >= gpiod_chip_num_lines(chip_)) {
    throw GpioError(where + ": no such line (the chip has " +
                    std::to_string(gpiod_chip_num_lines(chip_)) + " lines)");
  }
  gpiod_line* line = gpiod_chip_get_line(chip_, offset);
  if (line == nullptr) throw GpioError(where + ": " + std::strerror(errno));
  const int rc = output ? gpiod_line_request_output(line, config_.consumer.c_str(), 0)
                        : gpiod_line_request_input_flags(line, config_.consumer.c_str(),
                                                         GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW);
  if (rc != 0) {
    const int e = errno;
    std::string by;
    if (e == EBUSY) {
      gpiod_line_update(line);
      const char* consumer = gpiod_line_consumer(line);
      by = std::string(" (used by '") + (consumer != nullptr ? consumer : "?") + "')";
    }
    throw GpioError(where + ": cannot request the line: " + std::strerror(e) + by);
  }
  return line;
}

bool GpioSafetyIo::estop_open() {
  // Active-low: the value reads 1 when the line is low, the circuit open.
  const int v = gpiod_line_get_value(estop_);
  if (v < 0) ++io_errors_;
  return debouncer_.update(v != 0, monotonic_us());
}

void GpioSafetyIo::set_outputs(const fw::SafetyOutputs& o) {
  if (gpiod_line_set_value(enable_, o.drive_enable ? 1 : 0) != 0) ++io_errors_;
  if (gpiod_line_set_value(brake_, o.brake_release ? 1 : 0) != 0) ++io_errors_;
  if (gpiod_line_set_value(status_, o.status_ok ? 1 : 0) != 0) ++io_errors_;
}

}  // namespace fw_linux
