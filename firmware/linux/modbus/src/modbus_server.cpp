// The Modbus server's transports: TCP with several clients and RTU on a
// serial line, each in its own thread, answering through the RegisterBank.
#include "fw_linux/modbus_server.hpp"

#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <iostream>
#include <vector>

#include "fw_linux/mbap_framer.hpp"
#include "fw_linux/rtu_framer.hpp"

namespace fw_linux {

ModbusServer::ModbusServer(const PortConfig& config, ControlPanel& panel,
                           const ProgramFacts& program)
    : config_(config.modbus),
      allow_(parse_allow_list(config.modbus.allow, "modbus.allow")),
      bank_(config, panel, program) {
  wake_fd_ = eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  if (wake_fd_ < 0) throw ModbusError(std::string("Modbus: eventfd: ") + std::strerror(errno));
  auto fail = [this](const std::string& message) {
    close_all();
    throw ModbusError(message);
  };
  if (!config_.tcp.empty()) {
    const auto [host, port] = split_host_port(config_.tcp, "modbus.tcp");
    const std::string service = std::to_string(port);
    tcp_ = modbus_new_tcp_pi(host.c_str(), service.c_str());
    if (tcp_ == nullptr) {
      fail("modbus.tcp = " + config_.tcp + ": " + modbus_strerror(errno));
    }
    // The backlog is not the client limit: a burst of short connections
    // waits in it instead of being refused by the kernel.
    listen_fd_ = modbus_tcp_pi_listen(tcp_, kListenBacklog);
    if (listen_fd_ < 0) {
      fail("modbus.tcp = " + config_.tcp + ": cannot listen: " + modbus_strerror(errno));
    }
    sockaddr_storage addr{};
    socklen_t len = sizeof addr;
    getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
    tcp_port_ = addr.ss_family == AF_INET6
                    ? ntohs(reinterpret_cast<sockaddr_in6*>(&addr)->sin6_port)
                    : ntohs(reinterpret_cast<sockaddr_in*>(&addr)->sin_port);
    const std::uint32_t us = config_.byte_timeout_ms * 1000u;
    modbus_set_byte_timeout(tcp_, us / 1000000u, us % 1000000u);
    modbus_set_indication_timeout(tcp_, us / 1000000u, us % 1000000u);
  }
  if (!config_.rtu_device.empty()) {
    rtu_ = modbus_new_rtu(config_.rtu_device.c_str(), static_cast<int>(config_.rtu_baud),
                          config_.rtu_parity, 8, 1);
    if (rtu_ == nullptr) {
      fail("modbus.rtu_device = " + config_.rtu_device + ": " + modbus_strerror(errno));
    }
    modbus_set_slave(rtu_, static_cast<int>(config_.rtu_unit_id));
    if (modbus_connect(rtu_) != 0) {
      const std::string why = modbus_strerror(errno);
      modbus_free(rtu_);
      rtu_ = nullptr;
      fail("modbus.rtu_device = " + config_.rtu_device + ": cannot open: " + why);
    }
  }
  if (tcp_ != nullptr) tcp_thread_ = std::thread([this] { serve_tcp(); });
  if (rtu_ != nullptr) rtu_thread_ = std::thread([this] { serve_rtu(); });
}

ModbusServer::~ModbusServer() {
  const std::uint64_t one = 1;
  if (write(wake_fd_, &one, sizeof one) != sizeof one) {
    std::cerr << "delta_fw: Modbus: cannot wake the server threads\n";
  }
  if (tcp_thread_.joinable()) tcp_thread_.join();
  if (rtu_thread_.joinable()) rtu_thread_.join();
  close_all();
}

void ModbusServer::close_all() {
  if (tcp_ != nullptr) modbus_free(tcp_);
  if (listen_fd_ >= 0) close(listen_fd_);
  if (rtu_ != nullptr) {
    modbus_close(rtu_);
    modbus_free(rtu_);
  }
  close(wake_fd_);
}

ModbusStats ModbusServer::stats() const {
  std::lock_guard lock(stats_mutex_);
  return stats_;
}

void ModbusServer::count(std::uint64_t ModbusStats::*field) {
  std::lock_guard lock(stats_mutex_);
  ++(stats_.*field);
}

namespace {

std::uint64_t steady_ms() {
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                        std::chrono::steady_clock::now().time_since_epoch())
                                        .count());
}

}  // namespace

// One TCP client: its socket, the bytes of its request so far, and when it
// last sent a byte and finished a request.
struct ModbusServer::TcpClient {
  int fd{-1};
  MbapFramer framer;
  std::uint64_t last_byte_ms{0};
  std::uint64_t last_request_ms{0};
  std::string peer;       // its address
  bool may_write{false};  // its address is in modbus.allow
  bool refusal_logged{false};
};

void ModbusServer::serve_tcp() {
  std::vector<TcpClient> clients;
  std::vector<pollfd> fds;
  for (;;) {
    fds.assign({{wake_fd_, POLLIN, 0}, {listen_fd_, POLLIN, 0}});
    for (const TcpClient& c : clients) fds.push_back({c.fd, POLLIN, 0});
    if (poll(fds.data(), fds.size(), next_tcp_deadline_ms(clients)) < 0) {
      if (errno == EINTR) continue;
      std::cerr << "delta_fw: Modbus TCP: poll: " << std::strerror(errno) << "\n";
      break;
    }
    if (fds[0].revents != 0) break;
    std::vector<TcpClient> keep;
    for (std::size_t i = 0; i < clients.size(); ++i) {
      TcpClient& c = clients[i];
      if (fds[i + 2].revents == 0 || read_tcp_client(c)) {
        keep.push_back(std::move(c));
      } else {
        close(c.fd);
      }
    }
    close_timed_out_clients(keep);
    // After the clients: a hang-up in this round frees its place first.
    if ((fds[1].revents & POLLIN) != 0) accept_tcp_client(keep);
    clients = std::move(keep);
  }
  for (const TcpClient& c : clients) close(c.fd);
}

// The milliseconds until the first client's byte or idle timeout (-1: none).
int ModbusServer::next_tcp_deadline_ms(const std::vector<TcpClient>& clients) const {
  const std::uint64_t now = steady_ms();
  std::uint64_t first = UINT64_MAX;
  for (const TcpClient& c : clients) {
    first = std::min(first, c.framer.empty() ? c.last_request_ms + config_.idle_timeout_ms
                                             : c.last_byte_ms + config_.byte_timeout_ms);
  }
  if (first == UINT64_MAX) return -1;
  return first <= now ? 0 : static_cast<int>(std::min<std::uint64_t>(first - now, 60000));
}

// Reads what the client sent and answers every whole request in it; false
// when the connection is to go (the client hung up, or its header is no
// Modbus TCP header).
bool ModbusServer::read_tcp_client(TcpClient& c) {
  const ssize_t n = recv(c.fd, c.framer.space(), c.framer.space_left(), MSG_DONTWAIT);
  if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)) {
    if (!c.framer.empty()) count(&ModbusStats::receive_errors);  // cut short
    count(&ModbusStats::clients_dropped);
    return false;
  }
  if (n < 0) return true;
  const std::uint64_t now = steady_ms();
  c.last_byte_ms = now;
  c.framer.added(static_cast<std::size_t>(n));
  std::size_t length = 0;
  for (;;) {
    const MbapFramer::Next next = c.framer.next(length);
    if (next == MbapFramer::Next::kNeedMore) return true;
    if (next == MbapFramer::Next::kBadHeader) {
      // The stream's framing can no longer be trusted: the connection goes.
      count(&ModbusStats::receive_errors);
      count(&ModbusStats::clients_dropped);
      return false;
    }
    modbus_set_socket(tcp_, c.fd);
    count(&ModbusStats::requests);
    if (!refuse_write(c, c.framer.data(), length)) {
      const auto outcome = bank_.answer(tcp_, c.framer.data(), static_cast<int>(length));
      if (outcome == RegisterBank::Outcome::kException) count(&ModbusStats::exceptions);
    }
    c.framer.consume(length);
    c.last_request_ms = now;
  }
}

// A write from a client outside modbus.allow: answered with exception 1
// (illegal function: Modbus has no code for "not allowed"), counted, and
// logged once per connection. Reads are served to anyone.
bool ModbusServer::refuse_write(TcpClient& c, const std::uint8_t* request, std::size_t length) {
  constexpr std::size_t kFunctionAt = 7;  // after the MBAP header
  if (c.may_write || length <= kFunctionAt) return false;
  const std::uint8_t function = request[kFunctionAt];
  const bool write = function == 0x05 || function == 0x06 || function == 0x0F || function == 0x10 ||
                     function == 0x16 || function == 0x17;
  if (!write) return false;
  // Counted before the answer, which a client may act on at once.
  count(&ModbusStats::writes_refused);
  count(&ModbusStats::exceptions);
  modbus_reply_exception(tcp_, request, MODBUS_EXCEPTION_ILLEGAL_FUNCTION);
  if (!c.refusal_logged) {
    std::cerr << "delta_fw: Modbus TCP: refused a write (function 0x" << std::hex
              << static_cast<int>(function) << std::dec << ") from " << c.peer
              << ": not in modbus.allow = " << config_.allow
              << " (further writes on this connection are refused without a message)\n";
    c.refusal_logged = true;
  }
  return true;
}

// A request whose bytes stopped for byte_timeout_ms is dropped with its
// connection; a connection without a request for idle_timeout_ms is closed.
void ModbusServer::close_timed_out_clients(std::vector<TcpClient>& clients) {
  const std::uint64_t now = steady_ms();
  std::erase_if(clients, [&](const TcpClient& c) {
    const bool cut_short = !c.framer.empty() && now >= c.last_byte_ms + config_.byte_timeout_ms;
    const bool idle = c.framer.empty() && now >= c.last_request_ms + config_.idle_timeout_ms;
    if (!cut_short && !idle) return false;
    count(cut_short ? &ModbusStats::receive_errors : &ModbusStats::clients_idle_closed);
    count(&ModbusStats::clients_dropped);
    close(c.fd);
    return true;
  });
}

// Takes a new connection. At the limit, it displaces the client that has
// been idle longest, if that one has been idle for kDisplaceIdleMs (so idle
// connections cannot lock everybody out, and a client that is talking is
// never cut off); otherwise the new connection is closed.
void ModbusServer::accept_tcp_client(std::vector<TcpClient>& clients) {
  sockaddr_storage peer{};
  socklen_t peer_length = sizeof peer;
  const int fd =
      accept4(listen_fd_, reinterpret_cast<sockaddr*>(&peer), &peer_length, SOCK_CLOEXEC);
  if (fd < 0) return;
  const std::uint64_t now = steady_ms();
  if (clients.size() >= config_.max_clients) {
    auto idlest = clients.end();
    for (auto it = clients.begin(); it != clients.end(); ++it) {
      if (it->framer.empty() && now >= it->last_request_ms + kDisplaceIdleMs &&
          (idlest == clients.end() || it->last_request_ms < idlest->last_request_ms)) {
        idlest = it;
      }
    }
    if (idlest == clients.end()) {
      count(&ModbusStats::clients_refused);
      close(fd);
      return;
    }
    count(&ModbusStats::clients_idle_closed);
    count(&ModbusStats::clients_dropped);
    close(idlest->fd);
    clients.erase(idlest);
  }
  TcpClient c;
  c.fd = fd;
  c.last_byte_ms = c.last_request_ms = now;
  c.peer = address_text(peer);
  c.may_write = allowed(allow_, peer);
  clients.push_back(std::move(c));
  count(&ModbusStats::clients_accepted);
}

// The serial line: bytes as the device gives them, framed by RtuFramer (by
// the function's length, or by the line's silence), frames for this unit
// answered.
void ModbusServer::serve_rtu() {
  const int fd = modbus_get_socket(rtu_);
  const std::uint64_t gap_ns = std::uint64_t{rtu_frame_gap_us(config_.rtu_baud)} * 1000u;
  const std::uint64_t byte_timeout_ns = std::uint64_t{config_.byte_timeout_ms} * 1000000u;
  RtuFramer framer;
  bool too_long = false;  // more bytes than an RTU frame has, until the silence
  for (;;) {
    std::size_t length = 0;
    const RtuFramer::Next next = framer.next(length);
    if (next == RtuFramer::Next::kFrame && !too_long) {
      answer_rtu_frame(framer.data(), length);
      framer.consume(length);
      continue;
    }
    // How long the line may stay quiet before the bytes so far end.
    const std::uint64_t wait_ns = next == RtuFramer::Next::kNeedMore ? byte_timeout_ns : gap_ns;
    const timespec wait{static_cast<time_t>(wait_ns / 1000000000u),
                        static_cast<long>(wait_ns % 1000000000u)};
    pollfd fds[2] = {{wake_fd_, POLLIN, 0}, {fd, POLLIN, 0}};
    const bool idle = next == RtuFramer::Next::kNothing && !too_long;
    const int ready = ppoll(fds, 2, idle ? nullptr : &wait, nullptr);
    if (ready < 0) {
      if (errno == EINTR) continue;
      std::cerr << "delta_fw: Modbus RTU: poll: " << std::strerror(errno) << "\n";
      break;
    }
    if (fds[0].revents != 0) break;
    if (ready == 0) {  // the line went quiet: the bytes so far are a frame, or are dropped
      if (next == RtuFramer::Next::kAtSilence && !too_long && framer.whole_at_silence(length)) {
        answer_rtu_frame(framer.data(), length);
      } else {
        count(&ModbusStats::receive_errors);  // a bad CRC, a frame cut short or too long
      }
      framer.clear();
      too_long = false;
      continue;
    }
    if ((fds[1].revents & POLLIN) == 0) {
      // The line hung up (a pseudo-terminal without its other side): wait
      // for it to come back, or for the end, without spinning.
      pollfd wake{wake_fd_, POLLIN, 0};
      if (poll(&wake, 1, 200) > 0) break;
      continue;
    }
    too_long = !read_rtu_bytes(fd, framer) || too_long;
  }
}

// Reads what the line has into the framer; false when it had more than an
// RTU frame can hold (those bytes are dropped).
bool ModbusServer::read_rtu_bytes(int fd, RtuFramer& framer) {
  if (framer.space_left() == 0) {
    std::uint8_t discard[64];
    (void)::read(fd, discard, sizeof discard);
    return false;
  }
  const ssize_t n = ::read(fd, framer.space(), framer.space_left());
  if (n > 0) framer.added(static_cast<std::size_t>(n));
  return true;
}

// A whole frame with a good CRC: answered if it is for this unit (or a
// broadcast); another unit's request or reply on a multi-drop line is let
// pass.
void ModbusServer::answer_rtu_frame(const std::uint8_t* frame, std::size_t length) {
  if (frame[0] != config_.rtu_unit_id && frame[0] != 0) return;
  count(&ModbusStats::requests);
  if (bank_.answer(rtu_, frame, static_cast<int>(length)) == RegisterBank::Outcome::kException) {
    count(&ModbusStats::exceptions);
  }
}

}  // namespace fw_linux
