#include "modbus_fixture.hpp"

#include <cerrno>

namespace fw_linux::modbus_test {

namespace mb = delta::modbus;

LoopThread::LoopThread(ControlPanel& panel) : coordinator_({}, false, &panel, messages_) {
  rig_.hw.gate_log(&panel.log_enabled());
  thread_ = std::thread([this] {
    while (!stop_.load()) {
      cycle();
      std::this_thread::sleep_for(std::chrono::microseconds(50));  // pacing, like the timer
    }
  });
}

LoopThread::~LoopThread() {
  stop_.store(true);
  thread_.join();
}

void LoopThread::cycle() {
  // Node 3's TPDO1 misses the deadline while late cycles are owed.
  const bool late = late_cycles_.load() > 0;
  if (late) late_cycles_.fetch_sub(1);
  rig_.bus.make_late(late ? delta::can::protocol::cob_id(delta::can::protocol::kTpdo1, 3) : ~0u);
  rig_.cycle();
  if (next_feed_forward_.load()) {
    EXPECT_TRUE(rig_.controller.set_feed_forward(feed_forward_));
    next_feed_forward_.store(false);
  }
  coordinator_.after_step(rig_.controller, rig_.hw, rig_.master);
  cycles_.fetch_add(1);
}

PortConfig modbus_config() {
  PortConfig c = Rig::config();
  c.modbus.tcp = "127.0.0.1:0";
  c.modbus.byte_timeout_ms = 100;
  return c;
}

Client::Client(int port) : ctx_(modbus_new_tcp("127.0.0.1", port)) {
  modbus_set_response_timeout(ctx_, 5, 0);
  connected_ = modbus_connect(ctx_) == 0;
}

Client::~Client() {
  modbus_close(ctx_);
  modbus_free(ctx_);
}

std::vector<std::uint16_t> Client::inputs() {
  std::vector<std::uint16_t> r(mb::kInputCount);
  if (modbus_read_input_registers(ctx_, 0, mb::kInputCount, r.data()) != mb::kInputCount) {
    r.clear();
  }
  return r;
}

std::int64_t Client::input(const char* name) {
  const auto r = inputs();
  return r.empty() ? -1 : mb::decode(mb::named(name), r.data());
}

int Client::write(const mb::Register& r, std::uint16_t v) {
  return modbus_write_register(ctx_, r.address, v) == 1 ? 0 : errno;
}

int Client::write_many(int first, const std::vector<std::uint16_t>& v) {
  return modbus_write_registers(ctx_, first, static_cast<int>(v.size()), v.data()) ==
                 static_cast<int>(v.size())
             ? 0
             : errno;
}

std::int64_t value(const std::uint16_t* regs, const char* name) {
  return mb::decode(mb::named(name), regs);
}

delta::BlendedFourierTrajectory path1_as_custom(double scale) {
  delta::BlendedFourierTrajectory t;
  EXPECT_TRUE(delta::make_fourier_excitation(delta::kDefaultGeometry, {0.0, 0.0, -0.42}, 5, 0.2,
                                             0.35, 1, t.fourier));
  for (unsigned j = 0; j < 3; ++j) {
    for (auto& a : t.fourier.a_rad_s[j]) a *= scale;
    for (auto& b : t.fourier.b_rad_s[j]) b *= scale;
  }
  t.blend_s = 1.0;
  t.periods = 2;
  return t;
}

Fixture::Fixture()
    : server(modbus_config(), panel, kFacts), loop(panel), client(server.tcp_port()) {}

void Fixture::SetUp() {
  ASSERT_TRUE(client.connected());
  ASSERT_TRUE(poll_until(client, [](const std::uint16_t* r) {
    return value(r, "state") == static_cast<int>(fw::State::kReady);
  }));
}

}  // namespace fw_linux::modbus_test
