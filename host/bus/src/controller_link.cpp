#include "host_id/controller_link.hpp"

#include <modbus/modbus.h>

#include <cerrno>
#include <sstream>

#include "delta/controller/vocabulary.hpp"
#include "delta/input_error.hpp"

namespace host_id {

namespace mb = delta::modbus;

HostPort parse_host_port(const std::string& host_port) {
  const auto colon = host_port.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == host_port.size()) {
    throw delta::InputError("expected HOST:PORT, got '" + host_port + "'");
  }
  HostPort hp{host_port.substr(0, colon), host_port.substr(colon + 1)};
  if (hp.port.find_first_not_of("0123456789") != std::string::npos || hp.port.size() > 5 ||
      std::stoi(hp.port) > 65535 || std::stoi(hp.port) == 0) {
    throw delta::InputError("the port must be a number from 1 to 65535, got '" + hp.port + "'");
  }
  return hp;
}

ControllerLink::ControllerLink(const std::string& host_port) : address_(host_port) {
  HostPort hp;
  try {
    hp = parse_host_port(host_port);
  } catch (const delta::InputError& e) {
    throw delta::InputError(std::string("--modbus: ") + e.what());
  }
  const auto& [host, port] = hp;
  ctx_ = modbus_new_tcp_pi(host.c_str(), port.c_str());
  if (ctx_ == nullptr)
    throw delta::InputError("--modbus " + host_port + ": " + modbus_strerror(errno));
  modbus_set_response_timeout(ctx_, 3, 0);
  if (modbus_connect(ctx_) != 0) {
    const std::string why = modbus_strerror(errno);
    modbus_free(ctx_);
    throw delta::InputError("cannot connect to the controller at " + host_port + ": " + why +
                            " (is delta_fw running with modbus.tcp set?)");
  }
}

ControllerLink::~ControllerLink() {
  modbus_close(ctx_);
  modbus_free(ctx_);
}

void ControllerLink::fail(const std::string& what) {
  throw delta::InputError("controller " + address_ + ": " + what + ": " + modbus_strerror(errno));
}

std::vector<std::uint16_t> ControllerLink::inputs() {
  std::vector<std::uint16_t> r(mb::kInputCount);
  if (modbus_read_input_registers(ctx_, 0, mb::kInputCount, r.data()) != mb::kInputCount) {
    fail("reading the input registers");
  }
  if (r[mb::named("protocol_version").address] != mb::kMapVersion) {
    throw delta::InputError("controller " + address_ + ": register map version " +
                            std::to_string(r[mb::named("protocol_version").address]) +
                            ", this host_id speaks version " + std::to_string(mb::kMapVersion));
  }
  return r;
}

std::vector<std::uint16_t> ControllerLink::holding() {
  std::vector<std::uint16_t> r(mb::kHoldingCount);
  if (modbus_read_registers(ctx_, 0, mb::kHoldingCount, r.data()) != mb::kHoldingCount) {
    fail("reading the holding registers");
  }
  return r;
}

void ControllerLink::write(std::uint16_t first, const std::vector<std::uint16_t>& values) {
  const int n = static_cast<int>(values.size());
  const int rc = n == 1 ? modbus_write_register(ctx_, first, values[0])
                        : modbus_write_registers(ctx_, first, n, values.data());
  if (rc == n) return;
  const int err = errno;
  std::ostringstream w;
  w << "writing";
  const mb::Register* at = mb::find(mb::Table::kHolding, first);
  if (n > 5) {  // a block (the custom trajectory): where it starts and how long
    w << " " << n << " registers from " << (at ? std::string(at->name) : std::to_string(first));
  }
  for (int i = 0; i < n && n <= 5; ++i) {
    const mb::Register* r = mb::find(mb::Table::kHolding, static_cast<std::uint16_t>(first + i));
    w << (i ? "," : "") << " " << (r ? r->name : "?") << " = "
      << values[static_cast<std::size_t>(i)];
  }
  const std::string what = w.str();
  if (err < MODBUS_ENOBASE) {
    errno = err;
    fail(what);
  }
  // A Modbus exception: the controller says why in its input registers.
  std::string why = modbus_strerror(err);
  std::vector<std::uint16_t> in(mb::kInputCount);
  if (modbus_read_input_registers(ctx_, 0, mb::kInputCount, in.data()) == mb::kInputCount) {
    const auto rejection = static_cast<mb::Rejection>(raw("last_rejection", in));
    const mb::Register* reg = mb::find(
        mb::Table::kHolding, static_cast<std::uint16_t>(raw("last_rejection_register", in)));
    why = std::string(mb::describe(rejection)) + " (register " + (reg ? reg->name : "?") +
          ", Modbus exception " + std::to_string(mb::exception_code(rejection)) + ")";
    if (rejection == mb::Rejection::kWrongState) {
      why += "; the controller is " + std::string(delta::controller::state_name(
                                          static_cast<delta::controller::State>(raw("state", in))));
    }
    if (rejection == mb::Rejection::kTrajectoryLimit) {
      why += ": " +
             std::string(delta::controller::trajectory_fault_name(
                 static_cast<delta::controller::TrajectoryFault>(raw("trajectory_check", in)))) +
             " at tick " + std::to_string(raw("trajectory_check_tick", in));
      if (raw("trajectory_check_joint", in) > 0) {
        why += ", joint " + std::to_string(raw("trajectory_check_joint", in));
      }
    }
  }
  throw delta::InputError("controller " + address_ + " refused " + what + ": " + why);
}

std::int64_t raw(const char* name, const std::vector<std::uint16_t>& table) {
  return mb::decode(mb::named(name), table.data());
}

double scaled(const mb::Register& r, const std::vector<std::uint16_t>& table) {
  return static_cast<double>(mb::decode(r, table.data())) * r.scale_num / r.scale_den;
}

}  // namespace host_id
