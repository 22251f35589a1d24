// The controller's EDS (docs/eds/delta_fw.eds) against the running node 16
// on vcan, as a CANopen tool would use it: every readable object it lists
// answers an SDO upload with the EDS's size, and with its default where the
// EDS gives one; the write-only ones refuse a read; and no object or
// sub-index that the EDS omits answers (the communication and manufacturer
// areas, 0x1000-0x2FFF, are scanned whole).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "delta/can/protocol.hpp"
#include "delta/can/sdo_channel.hpp"
#include "delta/canopen/eds.hpp"
#include "vcan_interface.hpp"

namespace {

namespace sdo = delta::can::sdo;
namespace p = delta::can::protocol;
using namespace std::chrono_literals;

const std::string kIface = hil::vcan_interface();
const std::string kBin = DELTA_BIN_DIR;

std::string at(std::uint16_t index, std::uint8_t sub) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%04X:%02X", index, sub);
  return b;
}

class ControllerEds : public ::testing::Test {
 protected:
  void SetUp() override {
    emu_.emplace(
        hil::Child::spawn({kBin + "/delta_drive_emu", "--can", kIface, "--plant", "lumped"}));
    ASSERT_TRUE(emu_->wait_for_output("ready on " + kIface, 30s)) << emu_->err();
    fw_.emplace(hil::Child::spawn({kBin + "/delta_fw", "--can", kIface, "--lockstep"}));
    ASSERT_TRUE(fw_->wait_for_output("delta_fw: ready", 60s)) << fw_->err();
  }
  void TearDown() override {
    if (fw_) fw_->terminate(30s);
    if (emu_) emu_->terminate(30s);
  }
  std::optional<hil::Child> emu_, fw_;
};

TEST_F(ControllerEds, EveryObjectItListsAnswersAsListedAndNoOtherDoes) {
  const delta::canopen::Eds eds = delta::canopen::read_eds(DELTA_EDS_DIR "/delta_fw.eds");
  delta::can::Socket socket =
      delta::can::Socket::open(kIface, {delta::can::sdo_response_filter(p::kControllerNode)});
  delta::can::SdoChannel channel(socket, p::kControllerNode, 500ms);
  std::vector<std::uint8_t> bytes;
  unsigned read = 0, defaults = 0;
  for (const auto& [key, v] : eds.variables) {
    const std::string where =
        at(v.index, v.subindex) + " (" + v.name + ", line " + std::to_string(v.line) + ")";
    const delta::can::SdoOutcome o =
        channel.upload(v.index, v.subindex, bytes, sdo::Transfer::kAuto, 4096);
    if (!delta::canopen::readable(v.access)) {
      EXPECT_EQ(o.abort, sdo::kAbortWriteOnly)
          << where << ": write-only, yet " << channel.describe(v.index, v.subindex, o);
      continue;
    }
    // A domain with nothing in it (0x2200:1 before a model is loaded)
    // answers "no data available", as CiA 301 has it.
    if (v.data_type == delta::canopen::data_type::kDomain && o.abort == sdo::kAbortNoData) continue;
    ASSERT_TRUE(o.ok()) << where << ": " << channel.describe(v.index, v.subindex, o);
    ++read;
    if (v.size_bytes() > 0) {
      EXPECT_EQ(bytes.size(), v.size_bytes())
          << where << " is " << delta::canopen::data_type_name(v.data_type);
    }
    if (const std::optional<std::uint64_t> d = v.default_value(p::kControllerNode)) {
      std::uint64_t value = 0;
      for (std::size_t i = 0; i < bytes.size() && i < 8; ++i) {
        value |= std::uint64_t{bytes[i]} << (8 * i);
      }
      EXPECT_EQ(value, *d) << where << ": the EDS's DefaultValue=" << v.default_text;
      ++defaults;
    }
  }
  EXPECT_GE(read, 50u);
  EXPECT_GE(defaults, 30u);
  // Nothing answers that the EDS omits: no other object in 0x1000-0x2FFF,
  // and no sub-index past an object's last.
  for (unsigned index = 0x1000; index <= 0x2FFF; ++index) {
    const auto i = static_cast<std::uint16_t>(index);
    if (eds.has_object(i)) continue;
    const delta::can::SdoOutcome o = channel.upload(i, 0, bytes, sdo::Transfer::kAuto, 4096);
    ASSERT_EQ(o.abort, sdo::kAbortObjectDoesNotExist)
        << at(i, 0) << " is not in the EDS, yet " << channel.describe(i, 0, o);
  }
  for (const auto& [key, v] : eds.variables) {
    const auto next = eds.variables.upper_bound({v.index, 0xFF});
    const bool last_of_object = std::next(eds.variables.find(key)) == next;
    if (!last_of_object || (v.subindex == 0 && !eds.find(v.index, 1))) continue;
    const auto sub = static_cast<std::uint8_t>(v.subindex + 1);
    const delta::can::SdoOutcome o =
        channel.upload(v.index, sub, bytes, sdo::Transfer::kAuto, 4096);
    EXPECT_EQ(o.abort, sdo::kAbortSubindexDoesNotExist)
        << at(v.index, sub) << " is past the EDS's last sub-index, yet "
        << channel.describe(v.index, sub, o);
  }
}

}  // namespace
