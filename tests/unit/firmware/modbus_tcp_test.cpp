// The Modbus TCP server against clients that misbehave (raw sockets: what
// libmodbus would never send), many clients at once, pymodbus, and its
// start-up errors.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <iostream>
#include <latch>
#include <thread>
#include <vector>

#include "modbus_fixture.hpp"

namespace fw_linux {
namespace {

namespace mb = delta::modbus;
using modbus_test::Client;
using modbus_test::Fixture;
using modbus_test::kFacts;
using modbus_test::value;
using std::chrono::milliseconds;
using std::chrono::steady_clock;

// A raw TCP connection, for what libmodbus would never send.
int raw_connect(int port) {
  const int s = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(static_cast<std::uint16_t>(port));
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(s, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(s);
    return -1;
  }
  return s;
}

// Reads until the peer closes or `ms` pass; returns the bytes read, or -1
// on timeout with the connection still open.
int read_until_closed(int s, int ms, std::vector<std::uint8_t>& got) {
  const auto deadline = steady_clock::now() + milliseconds(ms);
  for (;;) {
    const auto left = std::chrono::duration_cast<milliseconds>(deadline - steady_clock::now());
    if (left.count() <= 0) return -1;
    pollfd p{s, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left.count())) <= 0) return -1;
    std::uint8_t buf[300];
    const ssize_t n = recv(s, buf, sizeof buf, 0);
    if (n <= 0) return static_cast<int>(got.size());
    got.insert(got.end(), buf, buf + n);
  }
}

TEST_F(Fixture, MalformedRequestsAreAnsweredOrDroppedAndTheLoopNeverStalls) {
  const int port = server.tcp_port();
  // A write of 2 registers whose byte count says 3: exception 03.
  {
    const int s = raw_connect(port);
    ASSERT_GE(s, 0);
    const std::uint8_t req[] = {0, 1, 0, 0, 0, 10, 1, 0x10, 0, 0, 0, 2, 3, 0, 1, 0};
    ASSERT_EQ(send(s, req, sizeof req, 0), static_cast<ssize_t>(sizeof req));
    std::vector<std::uint8_t> got;
    pollfd p{s, POLLIN, 0};
    ASSERT_EQ(poll(&p, 1, 5000), 1);
    std::uint8_t buf[64];
    const ssize_t n = recv(s, buf, sizeof buf, 0);
    ASSERT_EQ(n, 9);
    EXPECT_EQ(buf[7], 0x90);
    EXPECT_EQ(buf[8], 0x03);
    close(s);
  }
  // A header whose length field disagrees with the request: the server closes.
  {
    const int s = raw_connect(port);
    const std::uint8_t req[] = {0, 1, 0, 0, 0x00, 0x95, 1, 0x03, 0, 0, 0, 1};
    ASSERT_EQ(send(s, req, sizeof req, 0), static_cast<ssize_t>(sizeof req));
    std::vector<std::uint8_t> got;
    EXPECT_EQ(read_until_closed(s, 5000, got), 0);
    close(s);
  }
  // Half a request, then silence: dropped after the byte timeout, while the
  // control loop keeps cycling and the next client is served.
  {
    const int s = raw_connect(port);
    const std::uint64_t cycles_before = loop.cycles();
    const std::uint8_t half[] = {0, 1, 0, 0, 0, 6, 1, 0x04};
    ASSERT_EQ(send(s, half, sizeof half, 0), static_cast<ssize_t>(sizeof half));
    std::vector<std::uint8_t> got;
    EXPECT_EQ(read_until_closed(s, 5000, got), 0) << "the half request must be dropped";
    EXPECT_GT(loop.cycles(), cycles_before + 100) << "the loop went on meanwhile";
    close(s);
    EXPECT_EQ(client.input("protocol_version"), mb::kMapVersion);
  }
  // A client that vanishes after its request, before the reply.
  for (int i = 0; i < 20; ++i) {
    const int s = raw_connect(port);
    const std::uint8_t req[] = {0, 1, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 73};
    ASSERT_EQ(send(s, req, sizeof req, 0), static_cast<ssize_t>(sizeof req));
    linger l{1, 0};  // reset, not a graceful close
    setsockopt(s, SOL_SOCKET, SO_LINGER, &l, sizeof l);
    close(s);
  }
  EXPECT_EQ(client.input("protocol_version"), mb::kMapVersion);
  const ModbusStats st = server.stats();
  EXPECT_GE(st.receive_errors, 2u);
  EXPECT_GE(st.exceptions, 1u);
}

// Sends a raw Modbus TCP request and reads one reply (empty on timeout).
std::vector<std::uint8_t> raw_exchange(int s, const std::vector<std::uint8_t>& req) {
  EXPECT_EQ(send(s, req.data(), req.size(), MSG_NOSIGNAL), static_cast<ssize_t>(req.size()));
  std::vector<std::uint8_t> got;
  const auto deadline = steady_clock::now() + std::chrono::seconds(5);
  while (steady_clock::now() < deadline) {
    pollfd p{s, POLLIN, 0};
    if (poll(&p, 1, 100) <= 0) continue;
    std::uint8_t buf[300];
    const ssize_t n = recv(s, buf, sizeof buf, 0);
    if (n <= 0) break;
    got.insert(got.end(), buf, buf + n);
    if (got.size() >= 6 && got.size() >= 6u + ((unsigned{got[4]} << 8) | got[5])) break;
  }
  return got;
}

// Functions the server does not serve get exception 01 with their own
// function code and the exception bit, whatever their payload, and the
// connection stays in step (fuzzing findings of #19: 0x83 was answered as
// 03 01; diagnostics 0x08 reset or timed out the connection).
TEST_F(Fixture, UnservedFunctionsGetExceptionOneAndTheConnectionStaysInStep) {
  const int s = raw_connect(server.tcp_port());
  ASSERT_GE(s, 0);
  const std::vector<std::uint8_t> high = {0, 7, 0, 0, 0, 6, 1, 0x83, 0, 0, 0, 1};
  EXPECT_EQ(raw_exchange(s, high), (std::vector<std::uint8_t>{0, 7, 0, 0, 0, 3, 1, 0x83, 0x01}));
  const std::vector<std::uint8_t> diagnostics = {0, 8, 0, 0, 0, 6, 1, 0x08, 0, 0, 0xA5, 0x37};
  EXPECT_EQ(raw_exchange(s, diagnostics),
            (std::vector<std::uint8_t>{0, 8, 0, 0, 0, 3, 1, 0x88, 0x01}));
  const std::vector<std::uint8_t> odd = {0, 9, 0, 0, 0, 5, 1, 0x2B, 0x0E, 0x01, 0x00};
  EXPECT_EQ(raw_exchange(s, odd), (std::vector<std::uint8_t>{0, 9, 0, 0, 0, 3, 1, 0xAB, 0x01}));
  // The same connection, in step: read input register 73 (the map version).
  const std::vector<std::uint8_t> read = {0, 10, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 1};
  const std::vector<std::uint8_t> reply = raw_exchange(s, read);
  ASSERT_EQ(reply.size(), 11u);
  EXPECT_EQ(reply[7], 0x04);
  close(s);
}

// A client that trickles its request (a byte every 70 ms, under the
// fixture's 100 ms byte timeout; the finding's was 150 ms under 200 ms) no
// longer holds the server: another client is answered at once (it waited
// 2.1 s before).
TEST_F(Fixture, ASlowClientDoesNotHoldTheOthers) {
  const int slow = raw_connect(server.tcp_port());
  ASSERT_GE(slow, 0);
  std::atomic<bool> done{false};
  std::thread trickle([&] {
    const std::uint8_t req[] = {0, 1, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 1};
    for (std::uint8_t b : req) {
      if (done.load()) break;
      if (send(slow, &b, 1, MSG_NOSIGNAL) != 1) break;
      std::this_thread::sleep_for(milliseconds(70));  // the attack's pace, not a wait
    }
  });
  std::this_thread::sleep_for(milliseconds(300));  // a few bytes into its request
  double worst_ms = 0;
  for (int i = 0; i < 5; ++i) {
    const auto t0 = steady_clock::now();
    EXPECT_EQ(client.input("protocol_version"), mb::kMapVersion);
    worst_ms = std::max(
        worst_ms, std::chrono::duration<double, std::milli>(steady_clock::now() - t0).count());
  }
  done.store(true);
  trickle.join();
  close(slow);
  // Before, the first read waited for the rest of the trickle (over 500 ms).
  EXPECT_LT(worst_ms, 250.0) << "a read waited behind the slow client";
}

// Idle connections cannot lock the others out: when the server is full, a
// new client displaces the one idle longest (idle at least 1 s); a client
// that is talking is never cut off (the limit test below).
TEST_F(Fixture, IdleConnectionsMakeWayForANewClient) {
  std::vector<int> idle;
  for (int i = 0; i < 7; ++i) {  // with the fixture's client: all 8 places
    idle.push_back(raw_connect(server.tcp_port()));
    ASSERT_GE(idle.back(), 0);
  }
  // The displacement is for clients idle 1 s: let that time pass.
  std::this_thread::sleep_for(milliseconds(1100));
  Client late(server.tcp_port());
  EXPECT_EQ(late.input("protocol_version"), mb::kMapVersion);
  EXPECT_GE(server.stats().clients_idle_closed, 1u);
  for (int s : idle) close(s);
}

// Many short connections from three clients at once are all served. (The
// listen backlog is no longer the client limit, 8 but 128; this test passes
// with either here, so it does not show that change: the fuzzing run's 15
// failures of 300 were not reproduced in-process.)
// 100 clients connecting at the same instant (a SCADA system's pollers after
// a network outage): the kernel queues every handshake, so each connect
// completes at once. With a listen backlog equal to the client limit (8,
// the finding of #19) the queue overflowed, the kernel dropped the extra
// handshakes, and those clients connected only after their SYN's first
// retransmission, 1 s later.
TEST_F(Fixture, SimultaneousConnectionsAreAllQueuedByTheKernel) {
  constexpr int kClients = 100;
  std::latch start(kClients);
  std::atomic<int> failed{0};
  std::atomic<std::int64_t> slowest_us{0};
  std::vector<std::thread> threads;
  for (int k = 0; k < kClients; ++k) {
    threads.emplace_back([&] {
      start.arrive_and_wait();
      const auto t0 = steady_clock::now();
      const int s = raw_connect(server.tcp_port());
      const auto us =
          std::chrono::duration_cast<std::chrono::microseconds>(steady_clock::now() - t0).count();
      std::int64_t seen = slowest_us.load();
      while (us > seen && !slowest_us.compare_exchange_weak(seen, us)) {
      }
      if (s < 0)
        ++failed;
      else
        close(s);
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(failed.load(), 0);
  EXPECT_LT(slowest_us.load(), 500000) << "a handshake waited for its SYN's retransmission";
}

TEST_F(Fixture, ABurstOfShortConnectionsIsServed) {
  std::atomic<int> failed{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t) {
    threads.emplace_back([&] {
      for (int i = 0; i < 100; ++i) {
        const int s = raw_connect(server.tcp_port());
        if (s < 0) {
          ++failed;
          continue;
        }
        const std::vector<std::uint8_t> reply =
            raw_exchange(s, {0, 1, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 1});
        if (reply.size() != 11u) ++failed;
        close(s);
      }
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(failed.load(), 0);
}

TEST_F(Fixture, ServesManyClientsAtOnceAndRefusesBeyondTheLimit) {
  // The fixture's client holds one of the 8 places; 7 more read at once.
  constexpr int kClients = 7;
  std::atomic<int> good{0};
  std::vector<std::thread> threads;
  for (int i = 0; i < kClients; ++i) {
    threads.emplace_back([&] {
      Client c(server.tcp_port());
      if (!c.connected()) return;
      int ok = 0;
      for (int k = 0; k < 100; ++k) ok += c.input("protocol_version") == mb::kMapVersion;
      good.fetch_add(ok);
    });
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(good.load(), kClients * 100);

  // Eight held open, the ninth is closed at once.
  std::vector<std::unique_ptr<Client>> held;
  for (int i = 0; i < 7; ++i) {
    held.push_back(std::make_unique<Client>(server.tcp_port()));
    ASSERT_EQ(held.back()->input("protocol_version"), mb::kMapVersion);
  }
  Client extra(server.tcp_port());
  modbus_set_response_timeout(extra.ctx(), 2, 0);
  EXPECT_EQ(extra.input("protocol_version"), -1);
  EXPECT_GE(server.stats().clients_refused, 1u);
  held.clear();
  Client after(server.tcp_port());
  EXPECT_EQ(after.input("protocol_version"), mb::kMapVersion) << "a place is free again";
}

// pymodbus (Debian's python3-pymodbus: a Modbus implementation that shares
// no code with ours or with libmodbus) as a TCP client: it reads both
// tables whole, writes a holding register with functions 6 and 16 and reads
// it back, and is told exceptions 02, 03 and 01 where the map says
// (pymodbus_client.py).
TEST_F(Fixture, PymodbusReadsAndWritesTheMapAndGetsItsExceptions) {
  ASSERT_EQ(access("/usr/bin/python3", X_OK), 0);
  const std::string args =
      " --port " + std::to_string(server.tcp_port()) + " --inputs " +
      std::to_string(mb::kInputCount) + " --holdings " + std::to_string(mb::kHoldingCount) +
      " --version-address " + std::to_string(mb::named("protocol_version").address) +
      " --version " + std::to_string(mb::kMapVersion) + " --write-address " +
      std::to_string(mb::kAmplitudeScale.address) + " --write-value 1500 --bad-value 2001";
  std::string out;
  FILE* p = popen(("/usr/bin/python3 " DELTA_PYMODBUS_CLIENT + args + " 2>&1").c_str(), "r");
  ASSERT_NE(p, nullptr);
  char buf[256];
  while (fgets(buf, sizeof buf, p) != nullptr) out += buf;
  const int status = pclose(p);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << out;
  EXPECT_NE(out.find("map version " + std::to_string(mb::kMapVersion)), std::string::npos) << out;
  // The write reached the controller's settings, as libmodbus reads them.
  std::uint16_t amplitude = 0;
  ASSERT_EQ(modbus_read_registers(client.ctx(), mb::kAmplitudeScale.address, 1, &amplitude), 1);
  EXPECT_EQ(amplitude, 1500);
  EXPECT_EQ(client.input("last_rejection"), static_cast<int>(mb::Rejection::kIllegalFunction));
  std::cout << out;
}

// A libmodbus client whose connection comes from `source` (a loopback
// address other than 127.0.0.1 stands for another machine).
modbus_t* client_from(const char* source, int port) {
  const int s = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in from{};
  from.sin_family = AF_INET;
  inet_pton(AF_INET, source, &from.sin_addr);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (bind(s, reinterpret_cast<sockaddr*>(&from), sizeof from) != 0 ||
      connect(s, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0) {
    close(s);
    return nullptr;
  }
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", port);
  modbus_set_socket(ctx, s);
  modbus_set_response_timeout(ctx, 5, 0);
  return ctx;
}

// modbus.allow (default: 127.0.0.1 and ::1): a client from 127.0.0.2 reads
// the registers but its writes get exception 1, counted and logged; the
// client from 127.0.0.1 still writes.
TEST_F(Fixture, WritesFromOutsideTheAllowListAreRefusedAndReadsAreServed) {
  modbus_t* other = client_from("127.0.0.2", server.tcp_port());
  ASSERT_NE(other, nullptr) << std::strerror(errno);
  std::vector<std::uint16_t> inputs(mb::kInputCount);
  EXPECT_EQ(modbus_read_input_registers(other, 0, mb::kInputCount, inputs.data()), mb::kInputCount)
      << modbus_strerror(errno);
  EXPECT_EQ(modbus_write_register(other, mb::kTrajectory.address, 2), -1);
  EXPECT_EQ(errno, EMBXILFUN) << modbus_strerror(errno);
  const std::uint16_t two[2] = {1, 1};
  EXPECT_EQ(modbus_write_registers(other, mb::kTrajectory.address, 1, two), -1);
  EXPECT_EQ(errno, EMBXILFUN);
  EXPECT_EQ(server.stats().writes_refused, 2u);
  EXPECT_EQ(client.write(mb::kTrajectory, 2), 0) << modbus_strerror(errno);
  modbus_close(other);
  modbus_free(other);
}

// The allow list's networks: IPv4 and IPv6 prefixes, an IPv4 client on an
// IPv6 socket, nobody for an empty list; a bad entry is named.
TEST(ModbusAllowListTest, NetworksAdmitTheirAddressesOnly) {
  const auto peer = [](const char* text) {
    sockaddr_storage s{};
    auto* v4 = reinterpret_cast<sockaddr_in*>(&s);
    auto* v6 = reinterpret_cast<sockaddr_in6*>(&s);
    if (inet_pton(AF_INET, text, &v4->sin_addr) == 1) {
      v4->sin_family = AF_INET;
    } else {
      EXPECT_EQ(inet_pton(AF_INET6, text, &v6->sin6_addr), 1) << text;
      v6->sin6_family = AF_INET6;
    }
    return s;
  };
  const auto list = parse_allow_list("192.168.10.0/24, 10.1.2.3, 2001:db8::/32", "test");
  EXPECT_TRUE(allowed(list, peer("192.168.10.77")));
  EXPECT_FALSE(allowed(list, peer("192.168.11.1")));
  EXPECT_TRUE(allowed(list, peer("10.1.2.3")));
  EXPECT_FALSE(allowed(list, peer("10.1.2.4")));
  EXPECT_TRUE(allowed(list, peer("2001:db8:5::1")));
  EXPECT_FALSE(allowed(list, peer("2001:db9::1")));
  EXPECT_TRUE(allowed(list, peer("::ffff:192.168.10.5")));
  const auto standard = parse_allow_list(kDefaultModbusAllow, "test");
  EXPECT_TRUE(allowed(standard, peer("127.0.0.1")));
  EXPECT_FALSE(allowed(standard, peer("127.0.0.2")));
  EXPECT_TRUE(allowed(standard, peer("::1")));
  EXPECT_FALSE(allowed(standard, peer("192.168.10.77")));
  EXPECT_FALSE(allowed(parse_allow_list("", "test"), peer("127.0.0.1")));
  for (const char* bad : {"192.168.10.0/33", "host.example", "10.0.0.0/x", "::1/129"}) {
    try {
      (void)parse_allow_list(bad, "delta.conf:3:1");
      ADD_FAILURE() << bad;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("delta.conf:3:1: modbus.allow: '"), std::string::npos)
          << e.what();
    }
  }
}

TEST(ModbusServerTest, StartUpErrorsNameTheAddressOrDevice) {
  ControlPanel panel;
  PortConfig c = Rig::config();
  c.modbus.rtu_device = "/dev/no-such-tty";
  try {
    ModbusServer s(c, panel, kFacts);
    FAIL() << "expected a ModbusError";
  } catch (const ModbusError& e) {
    EXPECT_NE(std::string(e.what()).find("modbus.rtu_device = /dev/no-such-tty: cannot open"),
              std::string::npos)
        << e.what();
  }
  // A port already taken.
  PortConfig a = Rig::config();
  a.modbus.tcp = "127.0.0.1:0";
  ModbusServer first(a, panel, kFacts);
  PortConfig b = Rig::config();
  b.modbus.tcp = "127.0.0.1:" + std::to_string(first.tcp_port());
  try {
    ModbusServer second(b, panel, kFacts);
    FAIL() << "expected a ModbusError";
  } catch (const ModbusError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot listen"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace fw_linux
