// The host's side of the controller's Modbus interface (docs/modbus.md),
// over TCP with libmodbus: the register map is common's. Errors are
// delta::InputErrors that say which controller, which register and why.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "delta/modbus/register_map.hpp"

struct _modbus;

namespace host_id {

struct HostPort {
  std::string host;
  std::string port;  // digits, 1 to 65535
};
// Splits "HOST:PORT"; InputError says what is wrong with it.
HostPort parse_host_port(const std::string& host_port);

class ControllerLink {
 public:
  // Connects to "HOST:PORT"; throws delta::InputError.
  explicit ControllerLink(const std::string& host_port);
  ~ControllerLink();
  ControllerLink(const ControllerLink&) = delete;
  ControllerLink& operator=(const ControllerLink&) = delete;

  // The whole input table (decode with delta::modbus::decode).
  std::vector<std::uint16_t> inputs();
  std::vector<std::uint16_t> holding();
  // Writes holding registers from `first`; a refusal throws delta::InputError with
  // the controller's reason (read back from last_rejection).
  void write(std::uint16_t first, const std::vector<std::uint16_t>& values);
  const std::string& address() const { return address_; }

 private:
  [[noreturn]] void fail(const std::string& what);
  std::string address_;
  _modbus* ctx_{nullptr};
};

// A register's value in its unit (raw * scale).
double scaled(const delta::modbus::Register& r, const std::vector<std::uint16_t>& table);
std::int64_t raw(const char* name, const std::vector<std::uint16_t>& table);

}  // namespace host_id
