// The emulator's fault injection: the --inject specs parsed, and each
// fault triggered on the bus at its simulated time.
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "delta/can/emcy.hpp"
#include "delta/can/protocol.hpp"
#include "emu/emulator.hpp"

namespace emu {

namespace p = delta::can::protocol;
namespace od = delta::can::od;
namespace sdo = delta::can::sdo;
namespace cia = delta::can::cia402;
using delta::can::Frame;

namespace {

double number_in(const std::string& text, const std::string& spec, const char* what) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v)) {
    throw std::invalid_argument("fault '" + spec + "': " + what + " must be a number, got '" +
                                text + "'");
  }
  return v;
}

// contact:FORCE_N:DX,DY,DZ:MS
FaultInjection parse_contact(const std::string& spec, const std::vector<std::string>& parts,
                             FaultInjection f) {
  if (parts.size() != 4) {
    throw std::invalid_argument("fault '" + spec +
                                "': expected contact:FORCE_N:DX,DY,DZ:MS@SECONDS");
  }
  f.kind = FaultKind::kContact;
  const double force = number_in(parts[1], spec, "the force");
  if (!(force > 0.0) || force > 10000.0) {
    throw std::invalid_argument("fault '" + spec +
                                "': the force must be above 0 and at most 10000 N");
  }
  std::array<double, 3> d{};
  std::stringstream ds(parts[2]);
  std::size_t n = 0;
  for (std::string c; std::getline(ds, c, ',');) {
    if (n == 3) throw std::invalid_argument("fault '" + spec + "': the direction is DX,DY,DZ");
    d[n++] = number_in(c, spec, "the direction");
  }
  const double norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (n != 3 || !(norm > 0.0)) {
    throw std::invalid_argument("fault '" + spec + "': the direction DX,DY,DZ must not be zero");
  }
  for (unsigned k = 0; k < 3; ++k) f.force_N[k] = force * d[k] / norm;
  const long ms = std::atol(parts[3].c_str());
  if (ms <= 0 || ms > 60000 || parts[3] != std::to_string(ms)) {
    throw std::invalid_argument("fault '" + spec + "': the duration must be 1 to 60000 ms");
  }
  f.arg_ms = static_cast<std::uint32_t>(ms);
  return f;
}

}  // namespace

FaultInjection parse_fault(const std::string& spec) {
  FaultInjection f;
  std::string body = spec;
  const auto at = spec.find('@');
  if (at != std::string::npos) {
    body = spec.substr(0, at);
    const std::string t = spec.substr(at + 1);
    char* end = nullptr;
    f.at_s = std::strtod(t.c_str(), &end);
    if (t.empty() || *end != '\0' || !(f.at_s >= 0)) {
      throw std::invalid_argument("fault '" + spec + "': time after '@' must be seconds >= 0");
    }
  }
  std::vector<std::string> parts;
  std::stringstream ss(body);
  for (std::string part; std::getline(ss, part, ':');) parts.push_back(part);
  if (parts.empty()) throw std::invalid_argument("fault '" + spec + "': no kind");
  const std::string& kind = parts[0];
  if (kind == "contact") return parse_contact(spec, parts, f);
  const bool needs_node = kind != "error-frame";
  if (kind == "heartbeat-drop") {
    f.kind = FaultKind::kHeartbeatDrop;
  } else if (kind == "silent") {
    f.kind = FaultKind::kSilent;
  } else if (kind == "error-frame") {
    f.kind = FaultKind::kErrorFrame;
  } else if (kind == "corrupt-pdo") {
    f.kind = FaultKind::kCorruptPdo;
  } else if (kind == "delay-pdo") {
    f.kind = FaultKind::kDelayPdo;
  } else if (kind == "overcurrent") {
    f.kind = FaultKind::kOvercurrent;
  } else {
    throw std::invalid_argument("fault '" + spec +
                                "': unknown kind (heartbeat-drop, silent, error-frame, "
                                "corrupt-pdo, delay-pdo, overcurrent, contact)");
  }
  const std::size_t expected = needs_node ? (f.kind == FaultKind::kDelayPdo ? 3u : 2u) : 1u;
  if (parts.size() != expected) {
    throw std::invalid_argument("fault '" + spec + "': expected " +
                                (expected == 1   ? std::string("KIND@SECONDS")
                                 : expected == 2 ? std::string("KIND:NODE@SECONDS")
                                                 : std::string("KIND:NODE:MS@SECONDS")));
  }
  if (needs_node) {
    const int node = std::atoi(parts[1].c_str());
    if (node < 1 || node > 3 || parts[1] != std::to_string(node)) {
      throw std::invalid_argument("fault '" + spec + "': the node must be 1, 2 or 3");
    }
    f.node = static_cast<std::uint8_t>(node);
  }
  if (f.kind == FaultKind::kDelayPdo) {
    const long ms = std::atol(parts[2].c_str());
    if (ms <= 0 || ms > 10000 || parts[2] != std::to_string(ms)) {
      throw std::invalid_argument("fault '" + spec + "': the delay must be 1 to 10000 ms");
    }
    f.arg_ms = static_cast<std::uint32_t>(ms);
  }
  return f;
}

void Emulator::trigger_faults() {
  for (FaultInjection& f : config_.faults) {
    if (f.kind == FaultKind::kContact && f.done && !f.ended &&
        simulated_s() + 1e-9 >= f.at_s + f.arg_ms * 1e-3) {
      f.ended = true;
      plant_->set_platform_force({0.0, 0.0, 0.0});
    }
    if (f.done || simulated_s() + 1e-9 < f.at_s) continue;
    f.done = true;
    Drive* d = f.node != 0 ? &drives_[f.node - p::kFirstDriveNode] : nullptr;
    switch (f.kind) {
      case FaultKind::kHeartbeatDrop:
        d->heartbeat_dropped = true;
        break;
      case FaultKind::kSilent:
        d->silent = true;
        break;
      case FaultKind::kCorruptPdo:
        d->corrupt_next = true;
        break;
      case FaultKind::kDelayPdo:
        d->delay_us = f.arg_ms * 1000;
        break;
      case FaultKind::kContact: {
        plant_->set_platform_force(f.force_N);
        if (config_.report) {
          const double magnitude =
              std::sqrt(f.force_N[0] * f.force_N[0] + f.force_N[1] * f.force_N[1] +
                        f.force_N[2] * f.force_N[2]);
          char line[96];
          std::snprintf(line, sizeof line, "contact: t_s=%.4f force_N=%.6g", simulated_s(),
                        magnitude);
          config_.report(line);
        }
        break;
      }
      case FaultKind::kOvercurrent:
        // The current loop sees a short: the drive trips as a real one would.
        enter_fault(*d, od::kEmcyOvercurrent);
        break;
      case FaultKind::kErrorFrame: {
        // linux/can/error.h: CAN_ERR_FLAG | CAN_ERR_CRTL, data[1] = CAN_ERR_CRTL_TX_PASSIVE;
        // then CAN_ERR_BUSOFF.
        Frame e;
        e.error_frame = true;
        e.id = 0x00000004u;
        e.dlc = 8;
        e.data[1] = 0x20;
        out_(e, 0);
        Frame off;
        off.error_frame = true;
        off.id = 0x00000040u;
        off.dlc = 8;
        out_(off, 0);
        break;
      }
    }
  }
}

}  // namespace emu
