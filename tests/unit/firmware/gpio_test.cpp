// The safety lines' libgpiod backend: the e-stop debouncing and the start-up
// errors (unit tests), and the lines themselves on a real kernel GPIO chip
// made with gpio-sim (GpioSimTest: a HIL test, run in hil/vcan-run's VM,
// whose kernel has gpio-sim built for it).
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "fw_linux/gpio_safety_io.hpp"
#include "gpio_sim.hpp"

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

TEST(GpioSimTest, DrivesTheLinesOfASimulatedChip) {
  // Registered only as a HIL test (tests/hil/CMakeLists.txt), in the VM
  // where hil/vcan-run loads gpio-sim: never reported as skipped there.
  const std::string why = delta::test::GpioSim::unavailable();
  ASSERT_TRUE(why.empty()) << why;
  delta::test::GpioSim sim;
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
