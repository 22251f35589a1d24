// The bus load a configuration plans (fw_linux/bus_load.hpp) against
// docs/protocol.md's table, and delta_fw's warning where it is too high.
#include "fw_linux/bus_load.hpp"

#include <gtest/gtest.h>

#include <string>

#include "fw_linux/config.hpp"
#include "port_test_support.hpp"

namespace fw_linux {
namespace {

TEST(BusLoadTest, TheDefaultCycleIsDocsTableRowWithTheHeartbeats) {
  const PortConfig c;  // 500 Hz, no velocity PDO, 1 Mbit/s, heartbeats every 50 ms
  const BusLoad load = bus_load(c);
  EXPECT_EQ(load.bits_per_cycle, 1270u);
  EXPECT_NEAR(load.percent, 64.02, 0.005);  // 63.5 % cyclic + 4 x 65 bits / 50 ms
  EXPECT_FALSE(bus_load_warning(c).has_value());
  EXPECT_EQ(describe_bus_load(c),
            "bus load: 64.0 % of 1000 kbit/s (can_bitrate), 1270 bits per cycle at 500 Hz and "
            "the heartbeats' 0.5 %");
}

TEST(BusLoadTest, ArmEncodersAt500HzAreWarnedWithThePeriodThatFits) {
  PortConfig c;
  c.arm_encoders = true;
  EXPECT_EQ(bus_load(c).bits_per_cycle, 1795u);
  const auto warning = bus_load_warning(c);
  ASSERT_TRUE(warning.has_value());
  EXPECT_NE(warning->find("bus load: 90.3 % of 1000 kbit/s"), std::string::npos) << *warning;
  // 2500 us (400 Hz) gives 72.3 %; 3125 us (320 Hz) 58.0 %.
  EXPECT_NE(warning->find("Set period_us = 3125 (320 Hz) or longer"), std::string::npos)
      << *warning;
  c.period_us = 3125;
  EXPECT_NEAR(bus_load(c).percent, 57.96, 0.005);
  EXPECT_FALSE(bus_load_warning(c).has_value());
}

TEST(BusLoadTest, AHalfSpeedBusAndTheSyncCounterAreCounted) {
  PortConfig c;
  c.velocity_pdo = true;
  c.sync_counter_overflow = 16;
  c.can_bitrate = 500000;
  // 250 Hz: 1760 bits a cycle, 89.0 % of 500 kbit/s with the heartbeats; at
  // 200 Hz 71.4 %, at 160 Hz 57.4 %.
  c.period_us = 4000;
  EXPECT_EQ(bus_load(c).bits_per_cycle, 1760u);
  const auto warning = bus_load_warning(c);
  ASSERT_TRUE(warning.has_value());
  EXPECT_NE(warning->find("of 500 kbit/s"), std::string::npos) << *warning;
  EXPECT_NE(warning->find("Set period_us = 6250 (160 Hz) or longer"), std::string::npos)
      << *warning;
}

TEST(BusLoadTest, TheBitRateIsAKeyWithinClassicalCansRange) {
  const PortConfig c = read_port_config(port_test::write_temp("can_bitrate = 250000\n"));
  EXPECT_EQ(c.can_bitrate, 250000u);
  EXPECT_THROW(read_port_config(port_test::write_temp("can_bitrate = 2000000\n")), ConfigError);
}

}  // namespace
}  // namespace fw_linux
