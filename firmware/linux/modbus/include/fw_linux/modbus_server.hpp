// The controller's Modbus server (libmodbus): TCP with several clients at
// once, and RTU on a serial device, each in its own thread, outside the
// control loop. The register map is common's (delta/modbus/register_map.hpp,
// docs/modbus.md); the loop is reached only through the ControlPanel.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "fw_linux/allow_list.hpp"
#include "fw_linux/config.hpp"
#include "fw_linux/control_panel.hpp"
#include "fw_linux/program_facts.hpp"

struct _modbus;
struct _modbus_mapping_t;

namespace fw_linux {

class RtuFramer;

// The server cannot start: the message names the address or device.
class ModbusError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ModbusStats {
  std::uint64_t requests{0};
  std::uint64_t exceptions{0};      // requests answered with a Modbus exception
  std::uint64_t receive_errors{0};  // bad CRC, a request cut short, a bad header
  std::uint64_t clients_accepted{0};
  std::uint64_t clients_refused{0};      // over modbus.max_clients
  std::uint64_t clients_dropped{0};      // closed on a receive error, a hang-up or idleness
  std::uint64_t clients_idle_closed{0};  // idle too long, or displaced when full
  std::uint64_t writes_refused{0};       // from a client outside modbus.allow
};

// The registers: settings, the status snapshot and the validation of
// writes. Shared by the TCP and RTU threads (one lock).
class RegisterBank {
 public:
  RegisterBank(const PortConfig& config, ControlPanel& panel, const ProgramFacts& program);
  ~RegisterBank();
  RegisterBank(const RegisterBank&) = delete;
  RegisterBank& operator=(const RegisterBank&) = delete;

  enum class Outcome { kReplied, kException, kDrop };
  // Answers one request as libmodbus received it on ctx: a reply or an
  // exception; kDrop (no answer) for a TCP frame whose MBAP header does not
  // match it (protocol id not 0, or a length field that disagrees), since
  // the stream's framing can no longer be trusted.
  Outcome answer(_modbus* ctx, const std::uint8_t* request, int length);

 private:
  struct Settings {
    std::uint16_t trajectory{0};
    std::uint16_t scale_permille{1000};
    std::uint16_t repetitions{0};  // 0 until written: the preset's
    bool log_enable{true};
    // The custom trajectory's block, as written (docs/modbus.md).
    std::array<std::uint16_t, delta::modbus::kCustomCount> custom{};
  };
  // Takes the holding register at `first + i` (one word, or both words of a
  // 32-bit register) into next; the rejection, or kNone.
  delta::modbus::Rejection take(Settings& next, delta::modbus::Command& command,
                                const delta::modbus::Register& r, const std::uint16_t* words,
                                unsigned available) const;
  bool serve(_modbus* ctx, const std::uint8_t* request, int length, int header);
  bool write(_modbus* ctx, const std::uint8_t* request, std::uint16_t first,
             const std::uint16_t* values, unsigned count);
  // Every register of a write taken into next, or the first rejection
  // (its address in refused_at); nothing changes yet.
  delta::modbus::Rejection take_all(Settings& next, delta::modbus::Command& command,
                                    std::uint16_t first, const std::uint16_t* values,
                                    unsigned count, std::uint16_t& refused_at) const;
  // A written command handed to the control loop, and its verdict answered.
  bool submit(_modbus* ctx, const std::uint8_t* request, delta::modbus::Command command,
              const PanelStatus& status);
  bool refuse(_modbus* ctx, const std::uint8_t* request, delta::modbus::Rejection why,
              std::uint16_t address, const fw::TrajectoryCheck& check = {});
  // What a trajectory is checked against: the controller's bounds with the
  // feed-forward the status says is in use.
  fw::TrajectoryBounds bounds(const PanelStatus& status) const;
  std::optional<fw::CheckedTrajectory> build(const Settings& s, const PanelStatus& status,
                                             fw::TrajectoryCheck& check) const;
  // The registers from the status and the settings, before each reply: the
  // input registers (state, run, faults, tracking, geometry, the last
  // refusal) and the holding ones (the settings as taken).
  void refresh();
  void refresh_inputs();
  void refresh_history_and_checks(const PanelStatus& s);
  void refresh_holding();

  const PortConfig config_;
  const ProgramFacts program_;
  const fw::ControllerConfig core_;
  ControlPanel& panel_;
  std::mutex mutex_;
  _modbus_mapping_t* mapping_;
  Settings settings_;
  std::optional<fw::CheckedTrajectory> checked_;  // for settings_, once built
  delta::modbus::Rejection last_rejection_{delta::modbus::Rejection::kNone};
  std::uint16_t last_rejection_register_{0};
  fw::TrajectoryCheck last_check_{};
};

class ModbusServer {
 public:
  // Opens what the configuration asks for (TCP listening socket, serial
  // device) and starts serving; throws ModbusError when one cannot open.
  ModbusServer(const PortConfig& config, ControlPanel& panel, const ProgramFacts& program);
  ~ModbusServer();  // stops the threads and closes everything
  ModbusServer(const ModbusServer&) = delete;
  ModbusServer& operator=(const ModbusServer&) = delete;

  // The TCP port listened on (the configured one, or the one the kernel
  // chose for port 0); 0 without TCP.
  int tcp_port() const { return tcp_port_; }
  ModbusStats stats() const;

 private:
  struct TcpClient;
  // A client idle this long makes way for a new one when the server is full.
  static constexpr std::uint64_t kDisplaceIdleMs = 1000;
  static constexpr int kListenBacklog = 128;

  void serve_tcp();
  int next_tcp_deadline_ms(const std::vector<TcpClient>& clients) const;
  bool read_tcp_client(TcpClient& c);
  void close_timed_out_clients(std::vector<TcpClient>& clients);
  void accept_tcp_client(std::vector<TcpClient>& clients);
  bool refuse_write(TcpClient& c, const std::uint8_t* request, std::size_t length);
  void serve_rtu();
  bool read_rtu_bytes(int fd, RtuFramer& framer);
  void answer_rtu_frame(const std::uint8_t* frame, std::size_t length);
  void count(std::uint64_t ModbusStats::*field);
  void close_all();  // what the constructor opened

  const ModbusConfig config_;
  const std::vector<AllowedNetwork> allow_;  // who may write over TCP
  RegisterBank bank_;
  int wake_fd_{-1};  // eventfd: the destructor wakes the threads with it
  _modbus* tcp_{nullptr};
  int listen_fd_{-1};
  int tcp_port_{0};
  _modbus* rtu_{nullptr};
  mutable std::mutex stats_mutex_;
  ModbusStats stats_;
  std::thread tcp_thread_;
  std::thread rtu_thread_;
};

}  // namespace fw_linux
