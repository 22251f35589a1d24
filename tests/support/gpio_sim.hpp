// A gpio-sim chip (Linux >= 5.17; in hil/vcan-run's VM built for Debian's
// kernel): made through configfs, its input lines driven by their pull and
// its output lines read from sysfs. For the GPIO tests, unit and HIL.
#pragma once

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace delta::test {

class GpioSim {
 public:
  static constexpr const char* kRoot = "/sys/kernel/config/gpio-sim";
  static std::string unavailable() {
    if (geteuid() != 0) return "needs root to create a gpio-sim chip";
    if (!std::filesystem::exists(kRoot)) {
      return "no gpio-sim here (/sys/kernel/config/gpio-sim missing: the kernel lacks "
             "CONFIG_GPIO_SIM or configfs is not mounted)";
    }
    return "";
  }
  GpioSim() {
    dir_ = std::string(kRoot) + "/delta-test-" + std::to_string(getpid());
    std::filesystem::create_directory(dir_);
    std::filesystem::create_directory(dir_ + "/bank0");
    put(dir_ + "/bank0/num_lines", "8");
    put(dir_ + "/live", "1");
    chip_ = get(dir_ + "/bank0/chip_name");
    device_ = get(dir_ + "/dev_name");
  }
  ~GpioSim() {
    put(dir_ + "/live", "0");
    std::filesystem::remove(dir_ + "/bank0");
    std::filesystem::remove(dir_);
  }
  const std::string& chip() const { return chip_; }
  void pull(unsigned line, bool up) { put(line_dir(line) + "/pull", up ? "pull-up" : "pull-down"); }
  int value(unsigned line) const { return std::stoi(get(line_dir(line) + "/value")); }

 private:
  std::string line_dir(unsigned line) const {
    return "/sys/devices/platform/" + device_ + "/" + chip_ + "/sim_gpio" + std::to_string(line);
  }
  static void put(const std::string& path, const std::string& v) { std::ofstream(path) << v; }
  static std::string get(const std::string& path) {
    std::string s;
    std::ifstream(path) >> s;
    return s;
  }
  std::string dir_, chip_, device_;
};

}  // namespace delta::test
