// The controller's node (node 16) on a recording bus, for its unit tests.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "delta/can/protocol.hpp"
#include "delta/can/sdo.hpp"
#include "delta/update/image_file.hpp"
#include "fw_linux/controller_node.hpp"

namespace fw_linux::testing {

namespace p = delta::can::protocol;
namespace sdo = delta::can::sdo;
using delta::can::Frame;

struct Recorder : FrameSink {
  std::vector<Frame> frames;
  bool send(const Frame& f) override {
    frames.push_back(f);
    return true;
  }
  std::vector<Frame> take() { return std::exchange(frames, {}); }
};

// The controller's node on a recording bus, with its program download
// (supervised by delta_boot when given a Supervision), stepped by hand.
struct NodeRig {
  explicit NodeRig(std::optional<boot::Supervision> supervision = std::nullopt,
                   const PortConfig& c = unstored())
      : config(c), program(std::move(supervision), controller_identity(version)) {}
  // The default configuration, with models loaded over the bus kept in
  // memory only (a test that stores one names its file).
  static PortConfig unstored() {
    PortConfig c;
    c.feed_forward_store = "";
    return c;
  }
  Recorder bus;
  PortConfig config;
  delta::update::Version version = delta::update::parse_version(DELTA_PROJECT_VERSION);
  ProgramDownload program;
  FeedForwardSlot feed_forward{config, controller_config(config)};
  ControllerNode node{bus, config, version, program, feed_forward};
  std::uint64_t now_us{0};
  sdo::Client client;
  std::size_t requests{0};                             // frames the client sent
  StepReport report{fw::Fault::kNone, 0, true, true};  // safe to update, ready

  void step(fw::Fault fault = fw::Fault::kNone, int cycles = 1) {
    for (int i = 0; i < cycles; ++i) {
      now_us += config.period_us;
      report.fault = fault;
      node.after_step(report, now_us);
    }
  }
  void frame(std::uint32_t id, std::uint8_t dlc, const std::array<std::uint8_t, 8>& data) {
    Frame f{};
    f.id = id;
    f.dlc = dlc;
    f.data = data;
    node.on_frame(f, now_us);
  }
  void nmt(std::uint8_t command, std::uint8_t node_id) {
    frame(p::cob_id(p::kNmt, 0), 2, {command, node_id});
  }
  // One whole transfer with common's client; the answers node 16 sent.
  void transfer() {
    for (int guard = 0; guard < 1000000 && client.status() == sdo::ClientStatus::kBusy; ++guard) {
      sdo::Payload request;
      if (!client.pending(request)) break;
      client.sent(now_us);
      ++requests;
      frame(p::cob_id(p::kSdoRx, p::kControllerNode), 8, request);
      for (const Frame& f : bus.take()) {
        if (f.id == p::cob_id(p::kSdoTx, p::kControllerNode)) client.on_frame(f.data, now_us);
      }
    }
  }
  std::string read_text(std::uint16_t index) {
    std::vector<std::uint8_t> buffer(64);
    client.upload(index, 0, buffer, sdo::Transfer::kAuto, now_us);
    transfer();
    EXPECT_EQ(client.status(), sdo::ClientStatus::kDone) << sdo::abort_meaning(client.abort_code());
    return std::string(buffer.begin(), buffer.begin() + client.uploaded_size());
  }
  std::uint32_t read(std::uint16_t index, std::uint8_t sub) {
    std::vector<std::uint8_t> buffer(4);
    client.upload(index, sub, buffer, sdo::Transfer::kAuto, now_us);
    transfer();
    EXPECT_EQ(client.status(), sdo::ClientStatus::kDone) << sdo::abort_meaning(client.abort_code());
    std::uint32_t v = 0;
    for (unsigned i = 0; i < client.uploaded_size(); ++i) v |= std::uint32_t{buffer[i]} << (8 * i);
    return v;
  }
  std::vector<std::uint8_t> heartbeats() {
    std::vector<std::uint8_t> states;
    for (const Frame& f : bus.take()) {
      if (f.id == p::kControllerHeartbeat.base_id) states.push_back(f.data[0]);
    }
    return states;
  }
};

}  // namespace fw_linux::testing
