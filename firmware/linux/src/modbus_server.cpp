#include "fw_linux/modbus_server.hpp"

#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/eventfd.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <vector>

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

std::uint16_t be16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>((p[0] << 8) | p[1]);
}

bool moving(const PanelStatus& s) {
  return s.state == fw::State::kRunning || s.state == fw::State::kStopping ||
         s.run_result == mb::RunResult::kRunning;
}

}  // namespace

RegisterBank::RegisterBank(const PortConfig& config, ControlPanel& panel)
    : config_(config),
      core_(controller_config(config)),
      panel_(panel),
      mapping_(
          modbus_mapping_new_start_address(0, 0, 0, 0, 0, mb::kHoldingCount, 0, mb::kInputCount)) {
  if (mapping_ == nullptr) throw ModbusError("Modbus: cannot allocate the register map");
  settings_.log_enable = panel.log_enabled().load();
  refresh();
}

RegisterBank::~RegisterBank() {
  modbus_mapping_free(mapping_);
}

void RegisterBank::refresh() {
  const PanelStatus s = panel_.status();
  std::uint16_t* in = mapping_->tab_input_registers;
  auto set = [in](const char* name, std::int64_t v) { mb::encode(mb::named(name), v, in); };
  set("firmware_version_major", DELTA_FW_VERSION_MAJOR);
  set("firmware_version_minor", DELTA_FW_VERSION_MINOR);
  set("firmware_version_patch", DELTA_FW_VERSION_PATCH);
  set("protocol_version", mb::kMapVersion);
  set("state", static_cast<int>(s.state));
  set("fault_code", static_cast<int>(s.fault));
  set("cycle_counter", s.cycle);
  set("period_us", config_.period_us);
  set("io", s.io_bits);
  set("run_id", s.run_id);
  set("run_result", static_cast<int>(s.run_result));
  set("run_tick", s.run_tick);
  set("run_length", s.run_length);
  set("log_records", s.log_records);
  set("stale_log_records", s.stale_log_records);
  set("fault_count", s.fault_count);
  for (unsigned k = 0; k < mb::kFaultHistoryLength; ++k) {
    mb::encode(mb::fault_history_code(k), static_cast<int>(s.fault_history[k].fault), in);
    mb::encode(mb::fault_history_cycle(k), s.fault_history[k].cycle, in);
  }
  set("last_rejection", static_cast<int>(last_rejection_));
  set("last_rejection_register", last_rejection_register_);
  set("trajectory_check", static_cast<int>(last_check_.fault));
  set("trajectory_check_tick", last_check_.tick);
  set("trajectory_check_joint", last_check_.joint + 1);
  auto um = [](double m) { return static_cast<std::int64_t>(m * 1e6 + 0.5); };
  set("upper_arm_length", um(config_.geometry.upper_arm_length_m));
  set("forearm_length", um(config_.geometry.forearm_length_m));
  set("base_radius", um(config_.geometry.base_radius_m));
  set("platform_radius", um(config_.geometry.platform_radius_m));
  const char* q[] = {"q1", "q2", "q3"};
  const char* tau[] = {"tau1", "tau2", "tau3"};
  for (unsigned j = 0; j < 3; ++j) {
    set(q[j], s.q_urad[j]);
    set(tau[j], s.tau_uNm[j]);
  }
  set("trajectory_count", static_cast<std::int64_t>(trajectory_names().size()));
  std::uint16_t* hold = mapping_->tab_registers;
  mb::encode(mb::kTrajectory, settings_.trajectory, hold);
  mb::encode(mb::kAmplitudeScale, settings_.scale_permille, hold);
  mb::encode(mb::kRepetitions, settings_.repetitions, hold);
  mb::encode(mb::kLogEnable, settings_.log_enable ? 1 : 0, hold);
  mb::encode(mb::kCommand, 0, hold);
}

bool RegisterBank::refuse(modbus_t* ctx, const std::uint8_t* request, mb::Rejection why,
                          std::uint16_t address, const fw::TrajectoryCheck& check) {
  last_rejection_ = why;
  last_rejection_register_ = address;
  last_check_ = check;
  modbus_reply_exception(ctx, request, mb::exception_code(why));
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

std::optional<fw::CheckedTrajectory> RegisterBank::build(const Settings& s,
                                                         fw::TrajectoryCheck& check) const {
  const std::vector<std::string> names = trajectory_names();
  try {
    const auto t = named_trajectory(names.at(s.trajectory), config_,
                                    TrajectoryParams{s.scale_permille, s.repetitions});
    if (!t) throw ConfigError("unknown trajectory");
    fw::CheckedTrajectory c = fw::CheckedTrajectory::check(core_.geometry, *t, core_.limits);
    check = c.result();
    if (!c.ok()) return std::nullopt;
    return c;
  } catch (const ConfigError&) {
    check = fw::TrajectoryCheck{fw::TrajectoryFault::kInvalidConfig, 0, -1};
    return std::nullopt;
  }
}

bool RegisterBank::write(modbus_t* ctx, const std::uint8_t* request, std::uint16_t first,
                         const std::uint16_t* values, unsigned count) {
  // Every register must be a holding register, and every value in range,
  // before anything changes.
  Settings next = settings_;
  mb::Command command = mb::Command::kNone;
  const std::size_t trajectories = trajectory_names().size();
  for (unsigned i = 0; i < count; ++i) {
    const unsigned a = first + i;
    const std::uint16_t v = values[i];
    const mb::Register* r =
        a <= 0xFFFF ? mb::find(mb::Table::kHolding, static_cast<std::uint16_t>(a)) : nullptr;
    const auto address = static_cast<std::uint16_t>(a);
    if (r == nullptr) return refuse(ctx, request, mb::Rejection::kIllegalAddress, address);
    bool ok = true;
    if (r == &mb::kTrajectory) {
      ok = v < trajectories;
      next.trajectory = v;
    } else if (r == &mb::kAmplitudeScale) {
      ok = v >= mb::kMinAmplitudeScale && v <= mb::kMaxAmplitudeScale;
      next.scale_permille = v;
    } else if (r == &mb::kRepetitions) {
      ok = v <= mb::kMaxRepetitions;
      next.repetitions = v;
    } else if (r == &mb::kLogEnable) {
      ok = v <= 1;
      next.log_enable = v == 1;
    } else if (r == &mb::kCommand) {
      ok = v <= static_cast<std::uint16_t>(mb::Command::kFaultReset);
      command = static_cast<mb::Command>(v);
    }
    if (!ok) return refuse(ctx, request, mb::Rejection::kOutOfRange, address);
  }

  // The trajectory's settings do not change while it runs, and a new
  // combination must pass the limits check.
  const PanelStatus status = panel_.status();
  const bool changed = next.trajectory != settings_.trajectory ||
                       next.scale_permille != settings_.scale_permille ||
                       next.repetitions != settings_.repetitions;
  if (changed && moving(status)) {
    return refuse(ctx, request, mb::Rejection::kWrongState, first);
  }
  std::optional<fw::CheckedTrajectory> checked = checked_;
  if (changed || (command == mb::Command::kStart && !checked)) {
    fw::TrajectoryCheck check;
    checked = build(next, check);
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

ModbusServer::ModbusServer(const PortConfig& config, ControlPanel& panel)
    : config_(config.modbus), bank_(config, panel) {
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
    listen_fd_ = modbus_tcp_pi_listen(tcp_, static_cast<int>(config_.max_clients));
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
    const std::uint32_t us = config_.byte_timeout_ms * 1000u;
    modbus_set_byte_timeout(rtu_, us / 1000000u, us % 1000000u);
    modbus_set_indication_timeout(rtu_, us / 1000000u, us % 1000000u);
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

void ModbusServer::serve_tcp() {
  std::vector<int> clients;
  std::uint8_t request[MODBUS_TCP_MAX_ADU_LENGTH];
  for (;;) {
    std::vector<pollfd> fds{{wake_fd_, POLLIN, 0}, {listen_fd_, POLLIN, 0}};
    for (int c : clients) fds.push_back({c, POLLIN, 0});
    if (poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      std::cerr << "delta_fw: Modbus TCP: poll: " << std::strerror(errno) << "\n";
      break;
    }
    if (fds[0].revents != 0) break;
    std::vector<int> keep;
    for (std::size_t i = 2; i < fds.size(); ++i) {
      const int c = fds[i].fd;
      if (fds[i].revents == 0) {
        keep.push_back(c);
        continue;
      }
      modbus_set_socket(tcp_, c);
      const int rc = modbus_receive(tcp_, request);
      const auto outcome = rc > 0 ? bank_.answer(tcp_, request, rc) : RegisterBank::Outcome::kDrop;
      if (rc > 0 && outcome != RegisterBank::Outcome::kDrop) {
        count(&ModbusStats::requests);
        if (outcome == RegisterBank::Outcome::kException) count(&ModbusStats::exceptions);
        keep.push_back(c);
      } else if (rc == 0) {
        keep.push_back(c);  // not for us
      } else {
        // A hang-up, a request cut short (byte timeout) or a bad header:
        // the connection goes; the client may reconnect.
        if (rc > 0 || errno != ECONNRESET) count(&ModbusStats::receive_errors);
        count(&ModbusStats::clients_dropped);
        close(c);
      }
    }
    // After the clients: a hang-up in this round frees its place first.
    if ((fds[1].revents & POLLIN) != 0) {
      const int c = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
      if (c >= 0) {
        if (keep.size() >= config_.max_clients) {
          count(&ModbusStats::clients_refused);
          close(c);
        } else {
          keep.push_back(c);
          count(&ModbusStats::clients_accepted);
        }
      }
    }
    clients = std::move(keep);
  }
  for (int c : clients) close(c);
}

void ModbusServer::serve_rtu() {
  std::uint8_t request[MODBUS_RTU_MAX_ADU_LENGTH];
  const int fd = modbus_get_socket(rtu_);
  for (;;) {
    pollfd fds[2] = {{wake_fd_, POLLIN, 0}, {fd, POLLIN, 0}};
    if (poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      std::cerr << "delta_fw: Modbus RTU: poll: " << std::strerror(errno) << "\n";
      break;
    }
    if (fds[0].revents != 0) break;
    if ((fds[1].revents & POLLIN) == 0) {
      // The line hung up (a pseudo-terminal without its other side): wait
      // for it to come back, or for the end, without spinning.
      pollfd wake{wake_fd_, POLLIN, 0};
      if (poll(&wake, 1, 200) > 0) break;
      continue;
    }
    const int rc = modbus_receive(rtu_, request);
    if (rc > 0) {
      count(&ModbusStats::requests);
      if (bank_.answer(rtu_, request, rc) == RegisterBank::Outcome::kException) {
        count(&ModbusStats::exceptions);
      }
    } else if (rc < 0) {
      count(&ModbusStats::receive_errors);  // bad CRC, a frame cut short
      modbus_flush(rtu_);
    }
  }
}

}  // namespace fw_linux
