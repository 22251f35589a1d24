// The safety lines' libgpiod backend: the e-stop debouncing, the start-up
// errors on this machine (no GPIO chips), and the lines themselves on a
// gpio-sim chip where the kernel has one (configfs, root); elsewhere that
// test is skipped, and says why.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "fw_linux/gpio_safety_io.hpp"

namespace fw_linux {
namespace {

TEST(EStopDebouncerTest, OpensAtOnceAndClosesOnlyAfterTheDebounceTime) {
  EStopDebouncer d(20000);
  EXPECT_FALSE(d.update(false, 0)) << "the first reading counts as is";
  EXPECT_TRUE(d.update(true, 2000)) << "an open reading counts in the same cycle";
  EXPECT_TRUE(d.update(false, 4000));
  EXPECT_TRUE(d.update(false, 5000));
  EXPECT_TRUE(d.update(true, 6000)) << "a bounce restarts the wait";
  EXPECT_TRUE(d.update(false, 8000));
  EXPECT_TRUE(d.update(false, 27999));
  EXPECT_FALSE(d.update(false, 28000)) << "closed for 20 ms since its first closed reading";
  EXPECT_TRUE(d.update(true, 30000));
}

TEST(EStopDebouncerTest, StartsOpenWhenTheFirstReadingIsOpen) {
  EStopDebouncer d(10000);
  EXPECT_TRUE(d.update(true, 0));
  EXPECT_TRUE(d.update(false, 5000));
  EXPECT_TRUE(d.update(false, 14999));
  EXPECT_FALSE(d.update(false, 15000));
}

TEST(GpioSafetyIoTest, AMissingChipFailsTheStartWithItsName) {
  GpioConfig c;
  c.chip = "/dev/gpiochip-delta-missing";
  try {
    GpioSafetyIo io(c);
    FAIL() << "expected a GpioError";
  } catch (const GpioError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("gpio.chip = /dev/gpiochip-delta-missing: cannot open the GPIO chip"),
              std::string::npos)
        << m;
  }
}

// gpio-sim (Linux >= 5.17, CONFIG_GPIO_SIM): a simulated chip made through
// configfs; the test drives the e-stop input by its pull and reads the
// outputs' values from sysfs.
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

TEST(GpioSimTest, DrivesTheLinesOfASimulatedChip) {
  const std::string why = GpioSim::unavailable();
  if (!why.empty()) GTEST_SKIP() << why;
  GpioSim sim;
  sim.pull(0, true);  // e-stop circuit closed: the active-low line high
  GpioConfig c;
  c.chip = sim.chip();
  c.estop_debounce_ms = 0;
  {
    GpioSafetyIo io(c);
    EXPECT_FALSE(io.estop_open());
    for (unsigned l : {1u, 2u, 3u}) EXPECT_EQ(sim.value(l), 0) << "outputs start off";
    io.set_outputs({true, true, true});
    for (unsigned l : {1u, 2u, 3u}) EXPECT_EQ(sim.value(l), 1);
    sim.pull(0, false);
    EXPECT_TRUE(io.estop_open());
    // A second user of the same lines is refused, naming the line.
    try {
      GpioSafetyIo second(c);
      FAIL() << "expected a GpioError";
    } catch (const GpioError& e) {
      EXPECT_NE(std::string(e.what()).find("gpio.estop_line = 0"), std::string::npos) << e.what();
    }
  }
  for (unsigned l : {1u, 2u, 3u}) EXPECT_EQ(sim.value(l), 0) << "released: disabled and braked";
  c.status_line = 12;
  try {
    GpioSafetyIo io(c);
    FAIL() << "expected a GpioError";
  } catch (const GpioError& e) {
    EXPECT_NE(std::string(e.what()).find("gpio.status_line = 12"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("no such line"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fw_linux
