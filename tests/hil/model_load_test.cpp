// Loading the identified model into the controller over CAN (docs/protocol.md,
// 0x2200) on vcan, with the real programs: delta_fw against the emulated
// drives, host_id model load and show, and a transfer cut off halfway on
// the bus itself. The model is kept across a restart of delta_fw.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "child_process.hpp"
#include "delta/can/protocol.hpp"
#include "delta/can/socketcan.hpp"
#include "scratch_directory.hpp"
#include "vcan_interface.hpp"

namespace {

namespace p = delta::can::protocol;
using namespace std::chrono_literals;

const std::string kIface = hil::vcan_interface();
const std::string kBin = DELTA_BIN_DIR;

using hil::ToolRun;

ToolRun host_id(std::vector<std::string> args) {
  args.insert(args.begin(), kBin + "/host_id");
  return hil::run_tool(args, 120s);
}

// A saved fit of the default robot (as host_id fit writes the parts read),
// with a platform mass that tells fits apart.
void write_result(const std::string& path, double platform_mass_kg, double upper_arm_m = 0.2) {
  std::ofstream(path) << "{\"format\": \"host_id-result/1\", \"model\": {\"name\": \"lumped\", "
                         "\"per_joint\": false, \"offsets\": false, "
                         "\"coulomb_smoothing_rad_s\": 0.01}, \"geometry\": "
                         "{\"upper_arm_length_m\": "
                      << upper_arm_m
                      << ", \"forearm_length_m\": 0.46, \"base_radius_m\": 0.1, "
                         "\"platform_radius_m\": 0.035}, \"parameters\": {\"arm_inertia\": "
                         "0.0072, \"arm_gravity_moment\": 0.441, \"platform_mass\": "
                      << platform_mass_kg
                      << ", \"viscous_friction_1\": 0.02, \"viscous_friction_2\": 0.025, "
                         "\"viscous_friction_3\": 0.018, \"coulomb_friction_1\": 0.06, "
                         "\"coulomb_friction_2\": 0.05, \"coulomb_friction_3\": 0.07}}";
}

std::string fit_line(const std::string& show) {
  const auto at = show.find("model: ");
  return at == std::string::npos ? "" : show.substr(at, show.find('\n', at) - at);
}

class ModelLoad : public ::testing::Test {
 protected:
  void SetUp() override {
    emu_.emplace(
        hil::Child::spawn({kBin + "/delta_drive_emu", "--can", kIface, "--plant", "lumped"}));
    ASSERT_TRUE(emu_->wait_for_output("ready on " + kIface, 30s)) << emu_->err();
    start_fw();
  }
  void TearDown() override {
    if (fw_) fw_->terminate(30s);
    if (emu_) emu_->terminate(30s);
  }
  void start_fw() {
    fw_.emplace(hil::Child::spawn({kBin + "/delta_fw", "--can", kIface, "--lockstep", "--set",
                                   "feed_forward.store=" + store_}));
    ASSERT_TRUE(fw_->wait_for_output("delta_fw: ready", 60s)) << fw_->err();
  }
  std::string path(const std::string& name) const { return scratch_.file(name); }

  const testsupport::ScratchDirectory scratch_{"delta_model"};
  const std::string store_ = scratch_.file("model.bin");
  std::optional<hil::Child> emu_, fw_;
};

TEST_F(ModelLoad, LoadedShownRefusedForAnotherRobotKeptOverACutTransferAndARestart) {
  ToolRun show = host_id({"model", "show", "--can", kIface});
  ASSERT_EQ(show.code, 0) << show.err;
  EXPECT_NE(show.out.find("feed-forward: nominal"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("model: none loaded"), std::string::npos) << show.out;

  write_result(path("a.json"), 0.42);
  const ToolRun load = host_id({"model", "load", path("a.json"), "--can", kIface});
  ASSERT_EQ(load.code, 0) << load.err;
  EXPECT_NE(load.err.find("loaded " + path("a.json") + " (lumped, fit 0x"), std::string::npos)
      << load.err;
  show = host_id({"model", "show", "--can", kIface});
  ASSERT_EQ(show.code, 0) << show.err;
  EXPECT_NE(show.out.find("feed-forward: model"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("platform_mass"), std::string::npos) << show.out;
  EXPECT_NE(show.out.find("0.42 kg"), std::string::npos) << show.out;
  const std::string loaded = fit_line(show.out);
  ASSERT_FALSE(loaded.empty());

  // Another robot's fit: refused by the controller, with its reason.
  write_result(path("other.json"), 0.5, 0.25);
  const ToolRun other = host_id({"model", "load", path("other.json"), "--can", kIface});
  EXPECT_EQ(other.code, 3) << other.err;
  EXPECT_NE(other.err.find("0x06040043"), std::string::npos) << other.err;
  EXPECT_NE(other.err.find("fitted for another geometry"), std::string::npos) << other.err;

  // A transfer cut off on the bus: the initiate and 5 of its 20 segments,
  // then nothing, as from a tool killed halfway. The controller gives up
  // (an abort frame) and keeps the model in use.
  delta::can::Socket bus =
      delta::can::Socket::open(kIface, {{p::cob_id(p::kSdoTx, p::kControllerNode), 0x7FF, false}});
  const auto send = [&](std::array<std::uint8_t, 8> data) {
    delta::can::Frame f;
    f.id = p::cob_id(p::kSdoRx, p::kControllerNode);
    f.dlc = 8;
    f.data = data;
    ASSERT_EQ(bus.send(f), delta::can::SendResult::kOk);
    ASSERT_TRUE(bus.wait_readable(2000ms));
    ASSERT_TRUE(bus.receive().has_value());
  };
  send({0x21, 0x00, 0x22, 0x01, 140, 0, 0, 0});  // initiate, size 140
  for (std::uint8_t i = 0; i < 5; ++i) {
    send({static_cast<std::uint8_t>((i % 2) << 4), 'D', 'M', 'D', 'L', 1, 0, 2});
  }
  ASSERT_TRUE(bus.wait_readable(5000ms)) << "the controller never gave up on the transfer";
  const auto abort = bus.receive();
  ASSERT_TRUE(abort.has_value());
  EXPECT_EQ(abort->frame.data[0], 0x80);  // an abort (its timeout)
  show = host_id({"model", "show", "--can", kIface});
  EXPECT_EQ(fit_line(show.out), loaded) << show.out;

  // A restart: the model loaded over the bus is in use again.
  fw_->terminate(30s);
  start_fw();
  EXPECT_NE(fw_->err().find("feed-forward: the lumped model, fit 0x"), std::string::npos)
      << fw_->err();
  show = host_id({"model", "show", "--can", kIface});
  EXPECT_EQ(fit_line(show.out), loaded) << show.out;
  EXPECT_NE(show.out.find("feed-forward: model"), std::string::npos) << show.out;
}

}  // namespace
