#include "fw_linux/modbus_server.hpp"

#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <iostream>
#include <string_view>
#include <vector>

#include "delta/controller/vocabulary.hpp"
#include "fw_linux/mbap_framer.hpp"
#include "fw_linux/rtu_framer.hpp"
#include "fw_linux/trajectories.hpp"

namespace fw_linux {

namespace mb = delta::modbus;

namespace {

constexpr std::uint8_t kReadHolding = 0x03;
constexpr std::uint8_t kReadInput = 0x04;
constexpr std::uint8_t kWriteSingle = 0x06;
constexpr std::uint8_t kWriteMultiple = 0x10;
constexpr unsigned kMaxReadCount = 125;   // Modbus: registers per read
constexpr unsigned kMaxWriteCount = 123;  // Modbus: registers per write

// An exception reply. libmodbus adds 0x80 to the request's function code in
// an int and stores a byte, so a request with a code of 0x80 or more (no
// such function exists) got a reply with the code's low 7 bits: 0x83 was
// answered as 03. Those replies are built here, with the code as sent (its
// exception bit already set).
void reply_exception(modbus_t* ctx, const std::uint8_t* request, std::uint8_t code) {
  const int h = modbus_get_header_length(ctx);
  const std::uint8_t function = request[h];
  if (function < 0x80) {
    modbus_reply_exception(ctx, request, code);
    return;
  }
  std::uint8_t reply[9];
  std::size_t n = 0;
  if (h == 7) {  // TCP: the request's transaction and unit, a length of 3
    const std::uint8_t header[] = {request[0], request[1], 0, 0, 0, 3, request[6]};
    std::memcpy(reply, header, sizeof header);
    n = sizeof header;
  } else {  // RTU: the unit, and the CRC after the PDU
    reply[n++] = request[0];
  }
  reply[n++] = function;
  reply[n++] = code;
  if (h != 7) {
    const std::uint16_t crc = modbus_crc16(reply, n);
    reply[n++] = static_cast<std::uint8_t>(crc & 0xFF);
    reply[n++] = static_cast<std::uint8_t>(crc >> 8);
  }
  const int fd = modbus_get_socket(ctx);
  // A TCP client may be gone: no SIGPIPE for that; its next read tells.
  const ssize_t sent = h == 7 ? send(fd, reply, n, MSG_NOSIGNAL) : ::write(fd, reply, n);
  (void)sent;
}

std::uint16_t be16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

// A register by its name, found at compile time: refresh() runs on every
// read, and named() at run time compares the name with every register's.
// A name not in the map does not compile.
consteval const mb::Register& reg(std::string_view name) {
  return mb::named(name);
}

bool moving(const PanelStatus& s) {
  return s.state == fw::State::kRunning || s.state == fw::State::kStopping ||
         s.run_result == mb::RunResult::kRunning;
}

}  // namespace

RegisterBank::RegisterBank(const PortConfig& config, ControlPanel& panel,
                           const ProgramFacts& program)
    : config_(config),
      program_(program),
      core_(controller_config(config)),
      panel_(panel),
      mapping_(
          modbus_mapping_new_start_address(0, 0, 0, 0, 0, mb::kHoldingCount, 0, mb::kInputCount)) {
  if (mapping_ == nullptr) throw ModbusError("Modbus: cannot allocate the register map");
  settings_.log_enable = panel.log_enabled().load();
  if (config.custom_block.size() == settings_.custom.size()) {
    std::copy(config.custom_block.begin(), config.custom_block.end(), settings_.custom.begin());
  }
  refresh();
}

RegisterBank::~RegisterBank() {
  modbus_mapping_free(mapping_);
}

void RegisterBank::refresh() {
  const PanelStatus s = panel_.status();
  std::uint16_t* in = mapping_->tab_input_registers;
  auto set = [in](const mb::Register& r, std::int64_t v) { mb::encode(r, v, in); };
  set(reg("firmware_version_major"), program_.version.major);
  set(reg("firmware_version_minor"), program_.version.minor);
  set(reg("firmware_version_patch"), program_.version.patch);
  set(reg("update_rollback"), static_cast<int>(program_.rolled_back));
  set(reg("tracking_run_id"), s.tracking_run_id);
  set(reg("tracking_ticks"), s.tracking_ticks);
  static constexpr const mb::Register* kRms[] = {&reg("tracking_rms_1"), &reg("tracking_rms_2"),
                                                 &reg("tracking_rms_3")};
  static constexpr const mb::Register* kMax[] = {&reg("tracking_max_1"), &reg("tracking_max_2"),
                                                 &reg("tracking_max_3")};
  for (unsigned j = 0; j < 3; ++j) {
    set(*kRms[j], s.tracking_rms_nrad[j]);
    set(*kMax[j], s.tracking_max_nrad[j]);
  }
  set(reg("feed_forward_mode"), static_cast<int>(s.feed_forward.mode));
  set(reg("model_fit_id"), s.model_fit_id);
  set(reg("protocol_version"), mb::kMapVersion);
  set(reg("state"), static_cast<int>(s.state));
  set(reg("fault_code"), static_cast<int>(s.fault));
  set(reg("cycle_counter"), s.cycle);
  set(reg("period_us"), config_.period_us);
  set(reg("io"), s.io_bits);
  set(reg("run_id"), s.run_id);
  set(reg("run_result"), static_cast<int>(s.run_result));
  set(reg("run_tick"), s.run_tick);
  set(reg("run_length"), s.run_length);
  set(reg("log_records"), s.log_records);
  set(reg("stale_log_records"), s.stale_log_records);
  set(reg("fault_count"), s.fault_count);
  static constexpr auto kHistory = [] {
    std::array<std::array<const mb::Register*, 2>, mb::kFaultHistoryLength> h{};
    for (unsigned k = 0; k < h.size(); ++k) {
      h[k] = {&mb::fault_history_code(k), &mb::fault_history_cycle(k)};
    }
    return h;
  }();
  for (unsigned k = 0; k < mb::kFaultHistoryLength; ++k) {
    set(*kHistory[k][0], static_cast<int>(s.fault_history[k].fault));
    set(*kHistory[k][1], s.fault_history[k].cycle);
  }
  set(reg("last_rejection"), static_cast<int>(last_rejection_));
  set(reg("last_rejection_register"), last_rejection_register_);
  set(reg("trajectory_check"), static_cast<int>(last_check_.fault));
  set(reg("trajectory_check_tick"), last_check_.tick);
  set(reg("trajectory_check_joint"), last_check_.joint + 1);
  auto um = [](double m) { return static_cast<std::int64_t>(m * 1e6 + 0.5); };
  set(reg("upper_arm_length"), um(config_.geometry.upper_arm_length_m));
  set(reg("forearm_length"), um(config_.geometry.forearm_length_m));
  set(reg("base_radius"), um(config_.geometry.base_radius_m));
  set(reg("platform_radius"), um(config_.geometry.platform_radius_m));
  static constexpr const mb::Register* kQ[] = {&reg("q1"), &reg("q2"), &reg("q3")};
  static constexpr const mb::Register* kTau[] = {&reg("tau1"), &reg("tau2"), &reg("tau3")};
  for (unsigned j = 0; j < 3; ++j) {
    set(*kQ[j], s.q_urad[j]);
    set(*kTau[j], s.tau_uNm[j]);
  }
  set(reg("trajectory_count"),
      static_cast<std::int64_t>(delta::controller::kTrajectoryNames.size()));
  std::uint16_t* hold = mapping_->tab_registers;
  mb::encode(mb::kTrajectory, settings_.trajectory, hold);
  mb::encode(mb::kAmplitudeScale, settings_.scale_permille, hold);
  mb::encode(mb::kRepetitions, settings_.repetitions, hold);
  mb::encode(mb::kLogEnable, settings_.log_enable ? 1 : 0, hold);
  mb::encode(mb::kCommand, 0, hold);
  std::copy(settings_.custom.begin(), settings_.custom.end(), hold + mb::kCustomFirst);
}

bool RegisterBank::refuse(modbus_t* ctx, const std::uint8_t* request, mb::Rejection why,
                          std::uint16_t address, const fw::TrajectoryCheck& check) {
  last_rejection_ = why;
  last_rejection_register_ = address;
  last_check_ = check;
  reply_exception(ctx, request, mb::exception_code(why));
  return false;
}

RegisterBank::Outcome RegisterBank::answer(modbus_t* ctx, const std::uint8_t* request, int length) {
  const int h = modbus_get_header_length(ctx);
  if (length < h + 1) return Outcome::kDrop;  // nothing to answer to
  if (h == 7 && (be16(request + 2) != 0 || be16(request + 4) != length - 6)) return Outcome::kDrop;
  std::lock_guard lock(mutex_);
  return serve(ctx, request, length, h) ? Outcome::kReplied : Outcome::kException;
}

bool RegisterBank::serve(modbus_t* ctx, const std::uint8_t* request, int length, int h) {
  const std::uint8_t function = request[h];
  switch (function) {
    case kReadHolding:
    case kReadInput: {
      if (length < h + 5) return refuse(ctx, request, mb::Rejection::kMalformed, 0);
      const std::uint16_t first = be16(request + h + 1);
      const std::uint16_t count = be16(request + h + 3);
      const unsigned size = function == kReadInput ? mb::kInputCount : mb::kHoldingCount;
      if (count < 1 || count > kMaxReadCount) {
        return refuse(ctx, request, mb::Rejection::kOutOfRange, first);
      }
      if (unsigned{first} + count > size) {
        return refuse(ctx, request, mb::Rejection::kIllegalAddress, first);
      }
      refresh();
      modbus_reply(ctx, request, length, mapping_);
      return true;
    }
    case kWriteSingle: {
      if (length < h + 5) return refuse(ctx, request, mb::Rejection::kMalformed, 0);
      const std::uint16_t value = be16(request + h + 3);
      return write(ctx, request, be16(request + h + 1), &value, 1) &&
             modbus_reply(ctx, request, length, mapping_) >= 0;
    }
    case kWriteMultiple: {
      if (length < h + 6) return refuse(ctx, request, mb::Rejection::kMalformed, 0);
      const std::uint16_t first = be16(request + h + 1);
      const std::uint16_t count = be16(request + h + 3);
      const unsigned bytes = request[h + 5];
      if (count < 1 || count > kMaxWriteCount || bytes != 2u * count ||
          length < h + 6 + static_cast<int>(bytes)) {
        return refuse(ctx, request, mb::Rejection::kMalformed, first);
      }
      std::uint16_t values[kMaxWriteCount];
      for (unsigned i = 0; i < count; ++i) values[i] = be16(request + h + 6 + 2 * i);
      return write(ctx, request, first, values, count) &&
             modbus_reply(ctx, request, length, mapping_) >= 0;
    }
    default:
      return refuse(ctx, request, mb::Rejection::kIllegalFunction, 0);
  }
}

fw::TrajectoryBounds RegisterBank::bounds(const PanelStatus& status) const {
  fw::TrajectoryBounds b = fw::trajectory_bounds(core_);
  b.feed_forward = status.feed_forward;  // the one in use, maybe a model loaded over the bus
  return b;
}

std::optional<fw::CheckedTrajectory> RegisterBank::build(const Settings& s,
                                                         const PanelStatus& status,
                                                         fw::TrajectoryCheck& check) const {
  const std::vector<std::string> names = trajectory_names();
  try {
    const TrajectoryParams params{s.scale_permille, s.repetitions};
    const auto t =
        s.trajectory == static_cast<std::uint16_t>(delta::controller::TrajectoryId::kCustom)
            ? std::optional(custom_trajectory(s.custom.data(), config_, params))
            : named_trajectory(names.at(s.trajectory), config_, params);
    if (!t) throw ConfigError("unknown trajectory");
    fw::CheckedTrajectory c = fw::CheckedTrajectory::check(bounds(status), *t);
    check = c.result();
    if (!c.ok()) return std::nullopt;
    return c;
  } catch (const ConfigError&) {
    check = fw::TrajectoryCheck{fw::TrajectoryFault::kInvalidConfig, 0, -1};
    return std::nullopt;
  }
}

mb::Rejection RegisterBank::take(Settings& next, mb::Command& command, const mb::Register& r,
                                 const std::uint16_t* words, unsigned available) const {
  const unsigned width = mb::width(r.type);
  if (available < width) return mb::Rejection::kIllegalAddress;  // half a 32-bit register
  const std::uint16_t v = words[0];
  bool ok = true;
  if (&r == &mb::kTrajectory) {
    ok = v < trajectory_names().size();
    next.trajectory = v;
  } else if (&r == &mb::kAmplitudeScale) {
    ok = v >= mb::kMinAmplitudeScale && v <= mb::kMaxAmplitudeScale;
    next.scale_permille = v;
  } else if (&r == &mb::kRepetitions) {
    ok = v <= mb::kMaxRepetitions;
    next.repetitions = v;
  } else if (&r == &mb::kLogEnable) {
    ok = v <= 1;
    next.log_enable = v == 1;
  } else if (&r == &mb::kCommand) {
    ok = v <= static_cast<std::uint16_t>(mb::Command::kFaultReset);
    command = static_cast<mb::Command>(v);
  } else {
    // The custom block: ranges of its 16-bit registers; any 32-bit angle.
    if (&r == &mb::kCustomBaseFrequency) ok = v >= 1 && v <= mb::kCustomMaxFrequency_mHz;
    if (&r == &mb::kCustomHarmonics) ok = v <= mb::kCustomMaxHarmonics;
    if (&r == &mb::kCustomPeriods) ok = v >= 1 && v <= mb::kMaxRepetitions;
    if (&r == &mb::kCustomBlend) ok = v >= 1 && v <= mb::kCustomMaxBlend_ms;
    for (unsigned k = 0; k < width; ++k) next.custom[r.address - mb::kCustomFirst + k] = words[k];
  }
  return ok ? mb::Rejection::kNone : mb::Rejection::kOutOfRange;
}

bool RegisterBank::write(modbus_t* ctx, const std::uint8_t* request, std::uint16_t first,
                         const std::uint16_t* values, unsigned count) {
  // Every register must be a holding register, and every value in range,
  // before anything changes.
  Settings next = settings_;
  mb::Command command = mb::Command::kNone;
  for (unsigned i = 0; i < count;) {
    const unsigned a = first + i;
    const mb::Register* r =
        a <= 0xFFFF ? mb::find(mb::Table::kHolding, static_cast<std::uint16_t>(a)) : nullptr;
    const auto address = static_cast<std::uint16_t>(a);
    // Not a register, or the second word of a 32-bit one alone.
    if (r == nullptr) return refuse(ctx, request, mb::Rejection::kIllegalAddress, address);
    const mb::Rejection why = take(next, command, *r, values + i, count - i);
    if (why != mb::Rejection::kNone) return refuse(ctx, request, why, address);
    i += mb::width(r->type);
  }

  // The trajectory's settings do not change while it runs, and a new
  // combination must pass the limits check.
  const PanelStatus status = panel_.status();
  const bool custom =
      next.trajectory == static_cast<std::uint16_t>(delta::controller::TrajectoryId::kCustom);
  const bool custom_changed = next.custom != settings_.custom;
  const bool changed = next.trajectory != settings_.trajectory ||
                       next.scale_permille != settings_.scale_permille ||
                       next.repetitions != settings_.repetitions || (custom && custom_changed);
  if (custom_changed && moving(status)) {
    return refuse(ctx, request, mb::Rejection::kWrongState, first);
  }
  if (changed && moving(status)) {
    return refuse(ctx, request, mb::Rejection::kWrongState, first);
  }
  std::optional<fw::CheckedTrajectory> checked = checked_;
  // Checked again (here, not in the control loop) where the controller's
  // bounds changed since: a model loaded over the bus changes the
  // feed-forward the check covers.
  const bool stale = checked && !checked->checked_against(bounds(status));
  if (changed || (command == mb::Command::kStart && (!checked || stale))) {
    fw::TrajectoryCheck check;
    checked = build(next, status, check);
    if (!checked) return refuse(ctx, request, mb::Rejection::kTrajectoryLimit, first, check);
  }
  settings_ = next;
  checked_ = checked;
  panel_.set_log_enabled(next.log_enable);

  if (command == mb::Command::kNone) return true;
  if (command == mb::Command::kStart && (status.state != fw::State::kReady || moving(status))) {
    return refuse(ctx, request, mb::Rejection::kWrongState, mb::kCommand.address);
  }
  PanelCommand c;
  c.kind = command;
  if (command == mb::Command::kStart) c.trajectory = checked_;
  c.trajectory_id = settings_.trajectory;
  const auto verdict =
      panel_.submit(std::move(c), std::chrono::milliseconds(config_.modbus.command_timeout_ms));
  if (!verdict) return refuse(ctx, request, mb::Rejection::kNotTaken, mb::kCommand.address);
  if (!verdict->accepted) {
    return refuse(ctx, request, verdict->why, mb::kCommand.address, verdict->check);
  }
  return true;
}

// --- the transports ---

ModbusServer::ModbusServer(const PortConfig& config, ControlPanel& panel,
                           const ProgramFacts& program)
    : config_(config.modbus), bank_(config, panel, program) {
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
    const auto outcome = bank_.answer(tcp_, c.framer.data(), static_cast<int>(length));
    c.framer.consume(length);
    c.last_request_ms = now;
    count(&ModbusStats::requests);
    if (outcome == RegisterBank::Outcome::kException) count(&ModbusStats::exceptions);
  }
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
  const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
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
